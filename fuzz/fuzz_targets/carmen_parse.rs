//! libFuzzer entry point; the body is [`oldbf_fuzz::carmen_parse::run`].
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    oldbf_fuzz::carmen_parse::run(data);
});
