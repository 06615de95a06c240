//! The model of the module on the line: the one the user named (`--module MODEL`), or else the one its
//! version string names (command 136 type 0, PD28-1021 TMCL manual §3.7.38), asked once and only when a
//! model's tables are needed (a parameter by name, a refusal explained, a parameter set).

use crate::{Client, HostError, Transport};
use tmcl_model::ModelSpec;

/// Why no model could be had.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    /// The user named a model that has no tables here.
    #[error(transparent)]
    UnknownId(#[from] tmcl_model::UnknownModel),
    /// The module's version string names none of the models.
    #[error("the module's version string is {version:?}, a model OpenTMCL has no parameter table of")]
    UnknownVersion {
        /// The version string the module answered.
        version: String,
    },
    /// The module could not be asked.
    #[error(transparent)]
    Host(#[from] HostError),
}

/// A model by its id (`pd28-1021`, `tmcm-1310`, ...), or an error listing the known ones.
pub fn model_by_id(id: &str) -> Result<&'static ModelSpec, ModelError> {
    Ok(tmcl_model::find(id)?)
}

/// The model, from the user's word or, once needed, from the module itself.
#[derive(Debug, Clone, Copy, Default)]
pub struct Models {
    known: Option<&'static ModelSpec>,
}

impl Models {
    /// From the model the user named (checked now), or none: then the module is asked when needed.
    pub fn new(module: Option<&str>) -> Result<Models, ModelError> {
        Ok(Models { known: module.map(model_by_id).transpose()? })
    }

    /// The model if it is known without asking.
    pub fn known(&self) -> Option<&'static ModelSpec> {
        self.known
    }

    /// The model, asking the module for its version string the first time it is needed.
    pub fn get<T: Transport>(&mut self, client: &mut Client<T>) -> Result<&'static ModelSpec, ModelError> {
        if let Some(model) = self.known {
            return Ok(model);
        }
        let version = client.version_string()?;
        let model = tmcl_model::by_version(&version).ok_or(ModelError::UnknownVersion { version })?;
        self.known = Some(model);
        Ok(model)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::MockTransport;
    use tmcl_model::{pd28_1021, MODELS};

    #[test]
    fn by_id_names_the_known_ones() {
        assert_eq!(model_by_id("pd28-1021").unwrap().id, pd28_1021::SPEC.id);
        let e = model_by_id("tmcm-9999").unwrap_err();
        assert!(matches!(&e, ModelError::UnknownId(u) if u.id == "tmcm-9999"));
        for model in MODELS {
            assert!(e.to_string().contains(model.id), "{e} lacks {}", model.id);
        }
        assert!(Models::new(Some("nope")).is_err());
    }

    #[test]
    fn a_named_model_sends_nothing() {
        let mut models = Models::new(Some("pd28-1021")).unwrap();
        let mut client = Client::new(MockTransport::new());
        assert_eq!(models.get(&mut client).unwrap().id, pd28_1021::SPEC.id);
        assert!(client.transport_mut().sent.is_empty());
    }

    /// The raw reply of command 136 type 0: the reply address, then the eight characters.
    fn version_reply(text: &[u8; 8]) -> Vec<u8> {
        let mut bytes = vec![2];
        bytes.extend_from_slice(text);
        bytes
    }

    #[test]
    fn the_module_is_asked_once() {
        let mut models = Models::new(None).unwrap();
        assert!(models.known().is_none());
        let mut transport = MockTransport::new();
        transport.push_input(&version_reply(b"1021V142"));
        let mut client = Client::new(transport);
        assert_eq!(models.get(&mut client).unwrap().id, pd28_1021::SPEC.id);
        let sent = client.transport_mut().sent.len();
        assert_eq!(sent, 9, "one request");
        assert_eq!(models.get(&mut client).unwrap().id, pd28_1021::SPEC.id);
        assert_eq!(client.transport_mut().sent.len(), sent, "asked once");
        assert_eq!(models.known().map(|m| m.id), Some(pd28_1021::SPEC.id));
    }

    #[test]
    fn a_version_of_no_model() {
        let mut models = Models::new(None).unwrap();
        let mut transport = MockTransport::new();
        transport.push_input(&version_reply(b"9999V100"));
        let mut client = Client::new(transport);
        let e = models.get(&mut client).unwrap_err();
        assert!(matches!(&e, ModelError::UnknownVersion { version } if version == "9999V100"), "{e:?}");
        assert!(models.known().is_none());
    }
}
