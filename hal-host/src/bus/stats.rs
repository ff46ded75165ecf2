//! Bus and port counters.

/// What happened at one port.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PortStats {
    /// Frames this port sent successfully (dropped ones included).
    pub tx_frames: u64,
    /// Frames delivered to this port.
    pub rx_frames: u64,
    /// Transmissions of this port destroyed by an error.
    pub tx_errors: u64,
    /// Frames this port could not understand because of its bit rate.
    pub bitrate_errors: u64,
    /// Error frames the port saw (while not bus-off).
    pub error_frames: u64,
    /// Times the port went bus-off.
    pub bus_off_count: u64,
}

/// Bus-wide counters at one moment; see [`BusStats::load_since`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BusStats {
    /// Bus time of the snapshot, in nanoseconds since the start.
    pub elapsed_ns: u64,
    /// Frames that completed on the wire (dropped ones included).
    pub frames: u64,
    /// Bits that went over the wire: frames with stuff bits and
    /// intermission, destroyed frames up to the error, error frames.
    pub bits: u64,
    /// Nanoseconds the bus was not idle (intermission included).
    pub busy_ns: u64,
    /// Error frames (corrupted frames and injected ones).
    pub error_frames: u64,
    /// Frames dropped by fault injection (sent, but received by nobody).
    pub dropped: u64,
    /// Receptions lost because a port's bit rate differed from the sender's.
    pub bitrate_errors: u64,
}

impl BusStats {
    /// Fraction of time the bus was busy between `earlier` and `self`
    /// (0.0 for an empty interval).
    pub fn load_since(&self, earlier: &BusStats) -> f64 {
        let span = self.elapsed_ns.saturating_sub(earlier.elapsed_ns);
        if span == 0 {
            return 0.0;
        }
        self.busy_ns.saturating_sub(earlier.busy_ns) as f64 / span as f64
    }

    /// Fraction of time the bus was busy since the start.
    pub fn load(&self) -> f64 {
        self.load_since(&BusStats::default())
    }
}
