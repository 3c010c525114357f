//! libFuzzer entry point; the body is [`oldbf_fuzz::config_parse::run`].
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    oldbf_fuzz::config_parse::run(data);
});
