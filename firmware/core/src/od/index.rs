//! The communication objects' indices, named as CiA 301 v4.2 §7.5.2 names
//! them (the core's counterpart of a generated dictionary's `index` module,
//! which names a device's own objects). A record that repeats (SDO server,
//! PDO) has its first index and, where the core matches a range, its last.

/// 0x1000 The first index of the communication area (below it: the data types).
pub const COMMUNICATION_AREA: u16 = 0x1000;
/// 0x1000 Device type.
pub const DEVICE_TYPE: u16 = 0x1000;
/// 0x1001 Error register.
pub const ERROR_REGISTER: u16 = 0x1001;
/// 0x1003 Pre-defined error field (the error history).
pub const PRE_DEFINED_ERROR_FIELD: u16 = 0x1003;
/// 0x1005 COB-ID SYNC message.
pub const COB_ID_SYNC: u16 = 0x1005;
/// 0x1006 Communication cycle period (µs).
pub const COMMUNICATION_CYCLE_PERIOD: u16 = 0x1006;
/// 0x1007 Synchronous window length (µs).
pub const SYNCHRONOUS_WINDOW_LENGTH: u16 = 0x1007;
/// 0x100C Guard time (ms).
pub const GUARD_TIME: u16 = 0x100C;
/// 0x100D Life time factor.
pub const LIFE_TIME_FACTOR: u16 = 0x100D;
/// 0x1010 Store parameters.
pub const STORE_PARAMETERS: u16 = 0x1010;
/// 0x1011 Restore default parameters.
pub const RESTORE_DEFAULT_PARAMETERS: u16 = 0x1011;
/// 0x1012 COB-ID time stamp object.
pub const COB_ID_TIME_STAMP: u16 = 0x1012;
/// 0x1014 COB-ID EMCY.
pub const COB_ID_EMCY: u16 = 0x1014;
/// 0x1015 Inhibit time EMCY (100 µs).
pub const INHIBIT_TIME_EMCY: u16 = 0x1015;
/// 0x1016 Consumer heartbeat time.
pub const CONSUMER_HEARTBEAT_TIME: u16 = 0x1016;
/// 0x1017 Producer heartbeat time (ms).
pub const PRODUCER_HEARTBEAT_TIME: u16 = 0x1017;
/// 0x1018 Identity object.
pub const IDENTITY: u16 = 0x1018;
/// 0x1019 Synchronous counter overflow value.
pub const SYNCHRONOUS_COUNTER_OVERFLOW: u16 = 0x1019;
/// 0x1029 Error behaviour.
pub const ERROR_BEHAVIOUR: u16 = 0x1029;
/// 0x1200 SDO server parameter, the first of 128.
pub const SDO_SERVER_PARAMETER: u16 = 0x1200;
/// 0x127F The last SDO server parameter.
pub const SDO_SERVER_PARAMETER_LAST: u16 = 0x127F;
/// 0x1400 RPDO communication parameter, the first of 512.
pub const RPDO_COMMUNICATION_PARAMETER: u16 = 0x1400;
/// 0x15FF The last RPDO communication parameter.
pub const RPDO_COMMUNICATION_PARAMETER_LAST: u16 = 0x15FF;
/// 0x1600 RPDO mapping parameter, the first of 512.
pub const RPDO_MAPPING_PARAMETER: u16 = 0x1600;
/// 0x17FF The last RPDO mapping parameter.
pub const RPDO_MAPPING_PARAMETER_LAST: u16 = 0x17FF;
/// 0x1800 TPDO communication parameter, the first of 512.
pub const TPDO_COMMUNICATION_PARAMETER: u16 = 0x1800;
/// 0x19FF The last TPDO communication parameter.
pub const TPDO_COMMUNICATION_PARAMETER_LAST: u16 = 0x19FF;
/// 0x1A00 TPDO mapping parameter, the first of 512.
pub const TPDO_MAPPING_PARAMETER: u16 = 0x1A00;
/// 0x1BFF The last TPDO mapping parameter.
pub const TPDO_MAPPING_PARAMETER_LAST: u16 = 0x1BFF;
/// 0x1F80 NMT startup (CiA 302-2).
pub const NMT_STARTUP: u16 = 0x1F80;
/// 0x2000 The first index past the communication area (manufacturer and
/// profile objects begin here).
pub const MANUFACTURER_SPECIFIC: u16 = 0x2000;
