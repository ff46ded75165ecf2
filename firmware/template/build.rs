//! The object dictionary of `device.eds`, as `OUT_DIR/od.rs` (see `src/device.rs`).
fn main() {
    od_gen::build::generate("device.eds".as_ref(), "od");
}
