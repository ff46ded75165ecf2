//! Kübler Sendix M5868 multi-turn encoder: CiA 406 class C2 with LSS (seed 002).
//!
//! Defined by `eds/sendix.eds`; decisions where the manual is ambiguous are in
//! `docs/devices/sendix.md`.
//!
//! With nothing stored through LSS or 0x2101 the encoder starts as node 0x3F
//! at 250 kbit/s, as the manual's examples assume.

/// The object dictionary generated from `eds/sendix.eds`.
pub mod od {
    include!(concat!(env!("OUT_DIR"), "/sendix.rs"));
}

use canopen_core::abort::AbortCode;
use canopen_core::node::{Application, CommError, Ctx, NmtEvent, ServiceOptions, Source};
use canopen_core::profiles::cia406::diag::{BitEmcy, ErrorEmcy, FaultAlarm};
use canopen_core::profiles::cia406::{self, Config, Encoder, ManualShaft, PositionSource, SensorFault, SimulatedShaft};
use canopen_core::services::emcy::register;
use canopen_core::services::nmt::NmtState;
use canopen_core::services::store;
use canopen_core::time::{Duration, Instant};
use canopen_core::wire::emcy::EmcyCode;

/// What the Sendix's sensor chip reports besides the position: its
/// temperature and the limits and version its registers hold (the bytes of
/// the over-temperature EMCY, manual §5.8.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SensorTemperature {
    /// The temperature in 0.1 °C (0x2150).
    pub tenths: i16,
    /// The lower limit register (°C + 64).
    pub low: u8,
    /// The upper limit register (°C + 64).
    pub high: u8,
    /// The sensor version register.
    pub version: u8,
}

impl SensorTemperature {
    /// The temperature register (°C + 64), as the EMCY carries it.
    pub fn register(&self) -> u8 {
        (i32::from(self.tenths).div_euclid(10) + 64).clamp(0, 255) as u8
    }

    /// Outside its limits.
    pub fn out_of_limits(&self) -> bool {
        let r = self.register();
        r > self.high || r < self.low
    }
}

/// The room-temperature reading of a sensor that has no thermometer: 25.9 °C
/// (the manual's example 0x103), limits 0x20 (−32 °C) and 0xA2 (98 °C,
/// the default high limit of 0x2120 on the variants that have it), version 0x2E.
pub const ROOM_TEMPERATURE: SensorTemperature = SensorTemperature { tenths: 259, low: 0x20, high: 0xA2, version: 0x2E };

/// The Sendix's sensor: the position (CiA 406) and the temperature.
pub trait Sensor: PositionSource {
    /// The temperature and the chip's limits now.
    fn temperature(&mut self, now: Instant) -> SensorTemperature {
        let _ = now;
        ROOM_TEMPERATURE
    }
}

/// The shaft of the host, QEMU and bench images: 30 rpm clockwise
/// (0x4000 steps per turn), ±2 steps of noise, the full physical range of
/// 2^14 steps × 2^29 turns.
pub type Shaft = SimulatedShaft<0x2000, 2, 0x4000, 0x2000_0000>;

impl<const V: i32, const J: u16, const R: u32, const W: u32> Sensor for SimulatedShaft<V, J, R, W> {}

/// A sensor moved and heated by hand (tests and demos).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BenchSensor {
    /// The shaft.
    pub shaft: ManualShaft,
    /// What the temperature registers read.
    pub temperature: SensorTemperature,
}

impl BenchSensor {
    /// At rest at 0, room temperature, the physical counter wrapping at `range` steps (0: never).
    pub const fn new(range: u64) -> BenchSensor {
        BenchSensor { shaft: ManualShaft::with_range(range), temperature: ROOM_TEMPERATURE }
    }
}

impl PositionSource for BenchSensor {
    fn count(&mut self, now: Instant) -> Result<u64, SensorFault> {
        self.shaft.count(now)
    }
    fn range(&self) -> u64 {
        self.shaft.range()
    }
}

impl Sensor for BenchSensor {
    fn temperature(&mut self, _now: Instant) -> SensorTemperature {
        self.temperature
    }
}

/// The device's own rules (its hooks in the node): CiA 406 on its sensor
/// `P`, and what its manual asks of the firmware beyond the dictionary.
#[derive(Debug, Default)]
pub struct App<P = Shaft> {
    /// The encoder profile and its sensor.
    pub encoder: Encoder<P>,
    /// When the temperature is checked next.
    next_temperature: Instant,
    /// When 0x2150 is refreshed next.
    next_history: Instant,
}

impl<P: PositionSource + Copy> App<P> {
    /// The state at power-on on `sensor`: `const` and, for [`Shaft`], all
    /// zero bits ([`canopen_core::node`]).
    pub const fn with_sensor(sensor: P) -> Self {
        App { encoder: Encoder::new(sensor), next_temperature: Instant::ZERO, next_history: Instant::ZERO }
    }
}

impl App {
    /// The state at power-on: `const` and all zero bits ([`canopen_core::node`]).
    pub const NEW: App = App::with_sensor(SimulatedShaft::NEW);
}

/// 0x6000 bits of the M5868 (D15): code sequence, scaling, speed format, start in Operational.
const OPERATING_MASK: u16 = 0x5005;
/// 0x6000 bit 14: start in Operational (the M5868 has no 0x1F80, §5.5.15).
const START_OPERATIONAL: u16 = 0x4000;
/// 0x6505 bit 14: temperature error.
const WARNING_TEMPERATURE: u16 = 1 << 14;

/// EMCY codes of the manual (§5.8.1, §5.5.43–45).
pub mod emcy {
    use canopen_core::wire::emcy::EmcyCode;

    /// An alarm in 0x6503 (position error).
    pub const ALARM: EmcyCode = EmcyCode(0x1000);
    /// Overspeed and temperature (0x6505 bits 0 and 14).
    pub const TEMPERATURE: EmcyCode = EmcyCode(0x4200);
    /// Internal memory (0x6505 bit 15).
    pub const MEMORY: EmcyCode = EmcyCode(0x5200);
    /// "Internal Memory Error NVM": the memory failed a store.
    pub const NVM: EmcyCode = EmcyCode(0x5000);
    /// "Error Multiturn": the multi-turn counter failed.
    pub const MULTITURN: EmcyCode = EmcyCode(0x5051);
    /// Sensor sync failure (the sensor does not answer; 0x6503 bit 15).
    pub const SENSOR_SYNC: EmcyCode = EmcyCode(0xFF00);
    /// The over-temperature EMCY's first manufacturer byte: "sensor error register".
    pub const SENSOR_ERROR_REGISTER: u8 = 0x80;
}

/// §5.5.3: a position error sets bit 5 "device profile specific" of 0x1001
/// besides bit 0, so 0x1001 reads 0x21 while it lasts.
const POSITION_ERROR_REGISTER: u8 = register::PROFILE;

/// An EMCY with the manual's manufacturer bytes and no extra register bit.
const fn plain(code: EmcyCode, info: [u8; 5]) -> ErrorEmcy {
    ErrorEmcy { code, register: 0, info }
}

/// The profile as this variant has it.
const CIA406: Config = Config {
    operating_mask: OPERATING_MASK,
    speed_format_bit: 0x1000,
    // "Data update every 2 ms" (§3.8).
    update: Duration::from_millis(2),
    overspeed_rpm: 12_000,
    faults: &[
        // §5.5.43: a position error is 0x6503 bit 0 with EMCY 0x1000; §5.5.3: 0x1001 = 0x21.
        FaultAlarm {
            fault: SensorFault::Position,
            mask: cia406::ALARM_POSITION,
            emcy: ErrorEmcy { code: emcy::ALARM, register: POSITION_ERROR_REGISTER, info: [0; 5] },
        },
        // §5.8.1: 0x5051 "Error Multiturn", manufacturer bytes 03 05 00 00 00; the turns are
        // lost, so it is a position error too (0x6503 bit 0, 0x1001 = 0x21), D42.
        FaultAlarm {
            fault: SensorFault::Multiturn,
            mask: cia406::ALARM_POSITION,
            emcy: ErrorEmcy { code: emcy::MULTITURN, register: POSITION_ERROR_REGISTER, info: [0x03, 0x05, 0, 0, 0] },
        },
        // §5.8.1: 0xFF00 "Sensor Sync. Failure", manufacturer bytes 13 05 00 00 00.
        FaultAlarm { fault: SensorFault::Sync, mask: cia406::ALARM_DEVICE, emcy: plain(emcy::SENSOR_SYNC, [0x13, 0x05, 0, 0, 0]) },
    ],
    warnings: &[
        // Overspeed and temperature share 0x4200 (§5.5.45, §5.8.2).
        BitEmcy { mask: cia406::WARNING_OVERSPEED | WARNING_TEMPERATURE, emcy: plain(emcy::TEMPERATURE, [0; 5]) },
        BitEmcy { mask: cia406::WARNING_MEMORY, emcy: plain(emcy::MEMORY, [0; 5]) },
    ],
    // §5.8.1: 0x5000 "Internal Memory Error NVM", manufacturer bytes E1 01 00 00 00.
    storage_fault: Some(plain(emcy::NVM, [0xE1, 0x01, 0, 0, 0])),
    // D46: stored every hour of operation, counted on after a power cycle.
    operating_time_saved_every: 10,
};

/// How often the temperature is compared with the limits.
const TEMPERATURE_CHECK: Duration = Duration::from_secs(1);
/// How often 0x2150 is refreshed (§5.5.25: every 6 minutes).
const TEMPERATURE_HISTORY: Duration = Duration::from_secs(360);

impl<P: Sensor> App<P> {
    fn after_sample(&mut self, ctx: &mut Ctx<'_>) {
        // §5.5.26, D30: CRC-16/CCITT (0x1021, start 0x1021) over the raw position 0x600C as sent.
        let raw = ctx.read_u32(cia406::index::POSITION_RAW, 0).unwrap_or(0);
        let crc = crc16(&raw.to_le_bytes());
        if ctx.read_u32(RAW_POSITION_CRC, 0) != Some(u32::from(crc)) {
            let _ = ctx.set_value(RAW_POSITION_CRC, 0, &crc.to_le_bytes());
        }
    }

    /// A preset written: checked against the scaling (after the
    /// dictionary's length check), applied, its offset and the preset stored.
    fn preset(&mut self, ctx: &mut Ctx<'_>, data: &[u8]) -> Result<(), AbortCode> {
        if data.len() == 4 {
            self.encoder.check_write(ctx, &CIA406, PRESET, 0, data)?;
        }
        ctx.write_object(PRESET, 0, data)?;
        self.encoder.written(ctx, &CIA406, PRESET, 0);
        self.after_sample(ctx);
        ctx.save_objects(PRESET, PRESET)
    }

    fn temperature(&mut self, ctx: &mut Ctx<'_>) {
        let now = ctx.now();
        let t = self.encoder.source.temperature(now);
        if now >= self.next_history {
            self.next_history = now + TEMPERATURE_HISTORY;
            let _ = ctx.set_value(TEMPERATURE, 0, &t.tenths.to_le_bytes());
        }
        let was = ctx.read_u32(cia406::index::WARNINGS, 0).unwrap_or(0) as u16 & WARNING_TEMPERATURE != 0;
        let over = t.out_of_limits();
        let info = [emcy::SENSOR_ERROR_REGISTER, t.register(), t.low, t.high, t.version];
        let bits = if over { WARNING_TEMPERATURE } else { 0 };
        self.encoder.set_bits(ctx, cia406::index::WARNINGS, CIA406.warnings, WARNING_TEMPERATURE, bits, Some(info));
        if over && !was {
            // §5.5.12: temperature is a device-profile error (0x1029:02).
            ctx.error_behaviour(2);
        }
    }
}

impl<P: Sensor> Application for App<P> {
    /// §5.2.3, D5: 0x2100–0x2102 become permanent only through 0x2105.
    /// §5.5.15: 0x6000 bit 14 starts the encoder in Operational.
    /// §5.7.6 L3567: leaving LSS configuration with a new node-id resets the node.
    const OPTIONS: ServiceOptions = ServiceOptions {
        not_saved_by_1010: Some((BAUD_RATE, TERMINATION)),
        start_operational: Some((cia406::index::OPERATING_PARAMETERS, START_OPERATIONAL as u32)),
        lss_start_resets_node: true,
        // §5.3.7.3, §5.2.3 L839: type 255 is sent by the event (cyclic) timer; only with timer 0 on a change.
        tpdo_255_timer_only_with_timer: true,
        ..ServiceOptions::CIA301
    };
    // `rpdo_written` does nothing, and no hook triggers a TPDO.
    const PDO_CALLS: bool = false;
    // Its hooks send no frame outside CANopen.
    const RAW_FRAMES: bool = false;

    fn check_write(&mut self, ctx: &Ctx<'_>, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        match (index, sub, data) {
            // 100 kbit/s (code 3) has no CiA 305 bit timing: refused (D24).
            (BAUD_RATE, 0, [code]) if bit_rate_index(*code).is_none() && *code != NOT_SET => Err(AbortCode::InvalidValue),
            // §5.3.4.1 L1028: variable mapping changes only in Pre-operational.
            (0x1A00..=0x1A02, _, _) if ctx.state() != NmtState::PreOperational => Err(AbortCode::DeviceState),
            // L1214: transmission types 252/253 are not supported by the M58.
            (0x1800..=0x1802, 2, [252 | 253]) => Err(AbortCode::InvalidValue),
            // §5.5.13 L2057, D9: a valid TPDO COB-ID must keep bit 30 (no RTR).
            (0x1800..=0x1802, 1, [_, _, _, hi]) if hi & 0xC0 == 0 => Err(AbortCode::InvalidValue),
            _ => self.encoder.check_write(ctx, &CIA406, index, sub, data),
        }
    }

    fn written(&mut self, ctx: &mut Ctx<'_>, index: u16, sub: u8, _by: Source) {
        match (index, sub) {
            // D11: 0x6200 cyclic timer and TPDO1's event timer are one value, both ways.
            (CYCLIC_TIMER, 0) => {
                if let Ok(&[a, b]) = ctx.read(CYCLIC_TIMER, 0) {
                    let _ = ctx.write_object(0x1800, 5, &[a, b]);
                }
            }
            (0x1800, 5) => {
                if let Ok(&[a, b]) = ctx.read(0x1800, 5) {
                    let _ = ctx.write_object(CYCLIC_TIMER, 0, &[a, b]);
                }
            }
            _ => {
                self.encoder.written(ctx, &CIA406, index, sub);
                self.after_sample(ctx);
            }
        }
    }

    fn write(&mut self, ctx: &mut Ctx<'_>, index: u16, sub: u8, data: &[u8]) -> Option<Result<(), AbortCode>> {
        // Stores the device triggers; a failed store fails the write.
        match (index, sub) {
            // D17, D40: the preset becomes the position at once, and it is stored when written.
            (PRESET, 0) => Some(self.preset(ctx, data)),
            // §5.2.3: "save" to 0x2105 stores the bus parameters; anything else is refused.
            (SAVE_BUS, 0) if data != store::SAVE.to_le_bytes() => Some(Err(AbortCode::CannotStore)),
            (SAVE_BUS, 0) => Some(ctx.write_object(SAVE_BUS, 0, data).and_then(|()| ctx.save_objects(BAUD_RATE, TERMINATION))),
            _ => None,
        }
    }

    fn sample(&mut self, ctx: &mut Ctx<'_>) {
        self.encoder.sample(ctx, &CIA406);
        self.after_sample(ctx);
    }

    fn poll(&mut self, ctx: &mut Ctx<'_>) -> Option<Instant> {
        let next = self.encoder.poll(ctx, &CIA406);
        self.after_sample(ctx);
        if ctx.now() >= self.next_temperature {
            self.next_temperature = ctx.now() + TEMPERATURE_CHECK;
            self.temperature(ctx);
        }
        Some(next.map_or(self.next_temperature, |n| n.min(self.next_temperature)))
    }

    fn on_nmt(&mut self, ctx: &mut Ctx<'_>, event: NmtEvent) {
        // §5.5.12: bus-off is a communication error (0x1029:01); the heartbeat one the node handles itself.
        if event == NmtEvent::CommunicationError(CommError::BusOff) {
            ctx.error_behaviour(1);
        }
        if event == NmtEvent::ResetApplication {
            self.encoder.reset(ctx, &CIA406);
            self.after_sample(ctx);
            self.next_history = ctx.now();
            self.next_temperature = ctx.now();
            self.temperature(ctx);
        }
    }

    fn rpdo_written(&mut self, _ctx: &mut Ctx<'_>, _n: u8) {
        // No rule of this device reacts to an object an RPDO writes.
    }
}

/// CRC-16/CCITT, polynomial 0x1021, start value 0x1021 (§5.5.26).
pub fn crc16(data: &[u8]) -> u16 {
    crc16_ccitt(0x1021, data)
}

/// CRC-16 with polynomial 0x1021 (no reflection, no final XOR) from `init`.
pub fn crc16_ccitt(init: u16, data: &[u8]) -> u16 {
    let mut crc = init;
    for &b in data {
        crc ^= u16::from(b) << 8;
        for _ in 0..8 {
            crc = if crc & 0x8000 != 0 { (crc << 1) ^ 0x1021 } else { crc << 1 };
        }
    }
    crc
}

/// 0x2150 Actual temperature of the position sensor, 0.1 °C.
const TEMPERATURE: u16 = 0x2150;
/// 0x2162 Raw position CRC value.
const RAW_POSITION_CRC: u16 = 0x2162;
/// 0x6200 Cyclic timer (CiA 406), in ms.
const CYCLIC_TIMER: u16 = 0x6200;
/// 0x6003 Preset value.
const PRESET: u16 = 0x6003;
/// 0x2100 Baud rate, 0x2101 node address, 0x2102 bus termination.
const BAUD_RATE: u16 = 0x2100;
const NODE_ADDRESS: u16 = 0x2101;
const TERMINATION: u16 = 0x2102;
/// 0x2105 Save all bus parameters.
const SAVE_BUS: u16 = 0x2105;
/// 0x2100/0x2101 "not set".
const NOT_SET: u8 = 0xFF;

/// The CiA 305 bit-timing index of a 0x2100 code (§5.2.3 counts down from
/// 8 = 1 Mbit/s; 3 = 100 kbit/s has no CiA 305 entry).
fn bit_rate_index(code: u8) -> Option<u8> {
    match code {
        0..=2 | 4..=8 => Some(8 - code),
        _ => None,
    }
}

/// The node this device runs, on storage `S`.
pub type Node<S, P = Shaft> = od::Node<App<P>, S>;

/// The device entry for [`super::ALL`].
pub const DEVICE: super::Device = super::Device {
    name: "sendix",
    description: "Kübler Sendix M5868 multi-turn encoder: CiA 406 class C2 with LSS (seed 002).",
    dictionary: &od::DICTIONARY,
    default_node_id: 0x3F,
    startup: Some(startup),
};

/// Node-id 0x3F and 250 kbit/s: what the encoder uses when nothing is stored.
const FACTORY: (u8, u8) = (0x3F, 3);

/// The node-id and bit rate (CiA 305 table index) the encoder starts with
/// when LSS stored no configuration (the node applies an LSS store itself):
/// 0x2101 and 0x2100 from the stored parameters, where 0xFF means "not
/// set" and 0x2100 counts down (8 − table index, manual §5.2.3), else the
/// factory 0x3F at 250 kbit/s; no stored value gives a rate the boards
/// have no timing for. Decision D24 in docs/devices/sendix.md.
pub fn startup(storage: &mut dyn canopen_core::storage::Storage) -> (u8, Option<u8>) {
    let mut byte = [NOT_SET];
    let mut stored = |index| match store::stored_value(&od::DICTIONARY, storage, FACTORY.0, index, 0, &mut byte) {
        Some(1) => byte[0],
        _ => NOT_SET,
    };
    let node_id = match stored(NODE_ADDRESS) {
        id @ 1..=127 => id,
        _ => FACTORY.0,
    };
    // A code without CiA 305 timing (3, or any stored by an older image) starts at the factory rate.
    let bit_rate = bit_rate_index(stored(BAUD_RATE)).unwrap_or(FACTORY.1);
    (node_id, Some(bit_rate))
}
