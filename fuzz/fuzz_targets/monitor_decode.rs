//! The protocol monitor's decoders (`tmcl monitor`, `--log`): any bytes as a request, any bytes as its
//! reply, with each model's names or none. They never panic and always say something.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let models: Vec<Option<&'static tmcl_core::model::ModelSpec>> =
        std::iter::once(None).chain(tmcl_core::model::MODELS.iter().copied().map(Some)).collect();
    let model = models[usize::from(data.first().copied().unwrap_or(0)) % models.len()];
    let rest = data.get(1..).unwrap_or_default();
    let (request, reply) = rest.split_at(rest.len().min(9));
    assert!(!tmcl_serve::monitor::decode_request(request, model).text.is_empty());
    let (decoded, _, _) = tmcl_serve::monitor::decode_reply(reply, Some(request), model);
    assert!(!decoded.text.is_empty());
    let _ = tmcl_serve::monitor::decode_reply(reply, None, model);
});
