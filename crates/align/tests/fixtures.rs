//! The mesh and point fixtures in `fixtures/` are what this code writes: regenerate them
//! with `LAMPOST_WRITE_FIXTURES=1 cargo test -p lampost-align --test fixtures`.

use lampost_align::P3;
use lampost_mesh::{box_mesh, read_stl, write_ascii_stl};

fn root() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures")
}

#[test]
fn block_fixture_is_current() {
    let mesh = box_mesh(P3::zeros(), P3::new(100.0, 60.0, 50.0));
    let text = write_ascii_stl(&mesh, "block_100x60x50");
    let path = root().join("meshes/block.stl");
    if std::env::var_os("LAMPOST_WRITE_FIXTURES").is_some() {
        std::fs::write(&path, &text).expect("write");
    }
    let on_disk = std::fs::read(&path).expect("fixtures/meshes/block.stl");
    assert_eq!(
        read_stl(&on_disk).expect("reads"),
        read_stl(text.as_bytes()).expect("reads")
    );
}
