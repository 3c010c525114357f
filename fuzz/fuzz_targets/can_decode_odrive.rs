//! libFuzzer entry point; the body is [`oldbf_fuzz::can_decode_odrive::run`].
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    oldbf_fuzz::can_decode_odrive::run(data);
});
