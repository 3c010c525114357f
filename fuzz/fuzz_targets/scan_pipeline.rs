//! libFuzzer entry point; the body is [`oldbf_fuzz::scan_pipeline::run`].
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    oldbf_fuzz::scan_pipeline::run(data);
});
