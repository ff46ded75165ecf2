//! Dictionaries of test fixtures, generated from `tests/eds/` like the
//! devices are: `interop`, a CiA 301 node with objects of every transfer
//! size (1 to 200 bytes) and 4 + 4 PDOs, which the python-canopen interop
//! tests drive through `vnode --device interop`.

/// The interop test node.
pub mod interop {
    /// Its dictionary, generated from `tests/eds/interop.eds`.
    pub mod od {
        include!(concat!(env!("OUT_DIR"), "/interop.rs"));
    }
}
