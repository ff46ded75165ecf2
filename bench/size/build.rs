//! Generates the dictionaries `bench/size` weighs that are not a device's:
//! the interop test node (`tests/eds/interop.eds`, as hal-host does, but for
//! a `no_std` crate) and `ds301`, the CiA 301 profile CANopenNode ships
//! (`tests/eds-corpus/canopennode__DS301_profile.eds`), for the comparison
//! with CANopenNode in `docs/benchmarks.md`, once with every service and
//! once with CANopenNode's default set (`ds301-lean`).

use std::path::Path;

use canopen_core::od::Services;
use od_gen::build::fail;

/// Node guarding needs 0x100C/0x100D, which CANopenNode's profile leaves
/// out (CANopenNode adds them when `CO_CONFIG_NODE_GUARDING` is on); the
/// ds301 image has every service, so they are appended to its EDS.
const GUARDING: &str = "
[100C]
ParameterName=Guard time
ObjectType=0x7
DataType=0x0006
AccessType=rw
DefaultValue=0
PDOMapping=0

[100D]
ParameterName=Life time factor
ObjectType=0x7
DataType=0x0005
AccessType=rw
DefaultValue=0
PDOMapping=0
";

fn main() {
    od_gen::build::generate_strict(Path::new("../../tests/eds/interop.eds"), "interop", &[]);

    // Not strict: the file has empty vendor fields and `1:00PM` times (warnings).
    let ds301 = Path::new("../../tests/eds-corpus/canopennode__DS301_profile.eds");
    println!("cargo::rerun-if-changed={}", ds301.display());
    let text = std::fs::read_to_string(ds301).expect("the EDS corpus is in the repository");
    let listed = "[OptionalObjects]\nSupportedObjects=30\n";
    if !text.contains(listed) {
        fail(&format!("{}: error: [OptionalObjects] no longer lists 30 objects; update build.rs", ds301.display()));
    }
    let full = text.replace(listed, "[OptionalObjects]\nSupportedObjects=32\n31=0x100C\n32=0x100D\n") + GUARDING;
    // Neither reference keeps the acceptance list (`Services::acceptance`):
    // it is not a CiA 301/305 service but the input of a board that programs
    // its CAN controller's hardware filter, and this crate's board receives
    // every frame and never reads it, as CANopenNode's figure counts no
    // filter set-up (that is in its driver, outside the comparison).
    // Every service, block transfer included (no value of the profile is long enough to ask for it).
    generate("ds301", &full, Services { acceptance: false, ..Services::ALL });
    // CANopenNode's default configuration: segmented SDO without block, no
    // guarding, LSS, heartbeat consumer, EMCY history, SYNC, TIME, no storage.
    generate("ds301-lean", &text, Services { lss: true, block_sdo: false, guarding: false, time: true, storage: false, acceptance: false });
}

/// Generates `<name>.rs` from the profile `text` with `services`.
fn generate(name: &str, text: &str, services: Services) {
    let (eds, diagnostics) = od_gen::load("canopennode__DS301_profile.eds", text.as_bytes(), od_gen::Options { strict: false });
    if diagnostics.has_errors() {
        fail(&diagnostics.to_string());
    }
    match od_gen::codegen::generate_with(&eds, &diagnostics.file, services) {
        Ok(code) => od_gen::build::write_out(name, &code),
        Err(e) => fail(&format!("canopennode__DS301_profile.eds: error: {}", e.0)),
    }
}
