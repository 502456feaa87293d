//! The documents' generated tables match the code (run `cargo xtask docs` after a change).

use sim_host::docs::{memory_map, registers, splice};
use std::path::Path;

fn check(name: &str, block: &str) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../docs")
        .join(name);
    let text = std::fs::read_to_string(&path).unwrap();
    let want = splice(&text, block).expect("generated-block markers");
    assert!(
        text == want,
        "docs/{name} disagrees with the code: run `cargo xtask docs`"
    );
}

#[test]
fn memory_map_document_matches_vme_map() {
    check("memory-map.md", &memory_map());
}

#[test]
fn register_document_matches_regs() {
    check("registers.md", &registers());
}

#[test]
fn a_changed_document_is_detected() {
    let doc = "x\n<!-- generated: begin -->\nold\n<!-- generated: end -->\n";
    assert_ne!(splice(doc, &memory_map()).unwrap(), doc);
    assert_eq!(splice("no markers", "x"), None);
}
