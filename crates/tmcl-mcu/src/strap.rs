//! Which model an image runs: one image holds every model of [`tmcl_core::model::MODELS`] (they are
//! data), and a configuration word chooses one at start-up, as a board-identification strap or an option
//! byte would on a real board. Under QEMU the loader writes the word (`scripts/qemu-serve.sh --module`).
//!
//! The word is [`MAGIC`] in its upper 24 bits and the model's index in the low 8; anything else (RAM that
//! nobody wrote, an unknown index) selects the first model, the PD28-1021.

use tmcl_core::model::{ModelSpec, MODELS};

/// The upper 24 bits of a valid word: `"TMC"`.
pub const MAGIC: u32 = 0x544D_4300;

/// The word that selects the model at `index` of [`MODELS`].
pub const fn word(index: u8) -> u32 {
    MAGIC | index as u32
}

/// The model `word` selects.
pub fn model(word: u32) -> &'static ModelSpec {
    let index = if word & !0xFF == MAGIC { (word & 0xFF) as usize } else { 0 };
    MODELS.get(index).copied().unwrap_or(MODELS[0])
}

#[cfg(test)]
mod tests {
    use super::{model, word};
    use tmcl_core::model::MODELS;

    #[test]
    fn each_model_by_its_word_and_the_first_for_anything_else() {
        for (i, spec) in MODELS.iter().enumerate() {
            assert_eq!(model(word(i as u8)).id, spec.id);
        }
        assert_eq!(model(0).id, "pd28-1021");
        assert_eq!(model(0xFFFF_FFFF).id, "pd28-1021");
        assert_eq!(model(word(200)).id, "pd28-1021");
        assert_eq!(model(0x0000_0001).id, "pd28-1021");
    }
}
