//! Tests of the master.
