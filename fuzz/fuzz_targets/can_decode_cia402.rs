//! libFuzzer entry point; the body is [`oldbf_fuzz::can_decode_cia402::run`].
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    oldbf_fuzz::can_decode_cia402::run(data);
});
