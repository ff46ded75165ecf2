//! LSS slave. CiA 305 v3.0: the waiting and configuration states, switch
//! state global/selective, configure and inquire node-id and bit timing,
//! activate bit timing, store configuration, identify (non-configured)
//! remote slave and fastscan.
//!
//! The LSS address is 0x1018 sub 1..4. Node-id 0xFF means unconfigured. The
//! node-id configured here is *pending*; it becomes *active* when the node
//! resets communication (or, for a node that was unconfigured, when the
//! master switches it back to waiting). The same holds for the bit rate,
//! which only changes with "activate bit timing".

use crate::wire::lss::{answer, answer_u32, u32_at};

/// Node-id of an unconfigured node.
pub const UNCONFIGURED: u8 = 0xFF;

/// The LSS state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Only switch-state, identify and fastscan requests are served.
    Waiting,
    /// Configuration and inquiry requests are served.
    Configuration,
}

/// What the node must do after a request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LssAction {
    /// Nothing (no answer is due).
    None,
    /// The frame is no LSS request (a command specifier CiA 305 does not
    /// define, or switch state global with a mode other than 0 and 1).
    Malformed,
    /// Send this answer on 0x7E4.
    Answer(LssAnswer),
    /// Switch the bit rate to CiA 305 table index `index`: stop sending,
    /// wait `delay_ms`, switch, wait `delay_ms` again, resume.
    ActivateBitTiming {
        /// The switch delay (ms) of the request.
        delay_ms: u16,
        /// The new bit rate (table index).
        index: u8,
    },
    /// Store the pending node-id and bit-rate index; answer with the result
    /// (`store_result`).
    Store {
        /// Pending node-id to store.
        node_id: u8,
        /// Pending bit-rate table index to store.
        bit_rate: u8,
    },
    /// An unconfigured node got a node-id and left configuration: it starts
    /// with that node-id (reset communication, boot-up).
    Start(u8),
}

/// An answer on 0x7E4: the command specifier and bytes 1–4, little-endian
/// (bytes 5–7 are 0 in every LSS answer). Five bytes instead of the frame's
/// eight keep an [`LssAction`] in two registers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LssAnswer {
    /// The command specifier (byte 0).
    pub cs: u8,
    /// Bytes 1–4: an error code and its specific byte, or an address part.
    pub data: u32,
}

impl LssAnswer {
    /// The eight data bytes of the frame.
    pub fn bytes(self) -> [u8; 8] {
        answer_u32(self.cs, self.data)
    }
}

/// The answer `cs` with `byte1` (an error code, 0 = success, or the node-id).
fn reply(cs: u8, byte1: u8) -> LssAction {
    LssAction::Answer(LssAnswer { cs, data: u32::from(byte1) })
}

/// The LSS slave.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LssSlave {
    mode: Mode,
    address: [u32; 4],
    active_node_id: u8,
    pending_node_id: u8,
    pending_bit_rate: u8,
    supported_rates: u16,
    /// How many address parts of "switch state selective" matched so far.
    selective: u8,
    /// The address part fastscan compares next.
    fastscan_sub: u8,
    /// Whether the address matched every identify-remote-slave bound since
    /// the vendor-id (the first of the six, which starts a new check).
    identify: bool,
}

impl LssSlave {
    /// A slave with LSS address `address` (0x1018 sub 1..4), node-id
    /// `node_id` (0xFF = unconfigured), running at bit-rate table index
    /// `bit_rate` (the rate "activate bit timing" and "store configuration"
    /// take until "configure bit timing" sets another), able to run at the
    /// rates in `supported_rates` (bit n = table index n, as
    /// `DeviceInfo::baud_rates`). The rate in use is the node's
    /// (`Node::bit_rate`): no LSS service reads it, so the slave keeps none.
    pub const fn new(address: [u32; 4], node_id: u8, bit_rate: u8, supported_rates: u16) -> Self {
        LssSlave {
            mode: Mode::Waiting,
            address,
            active_node_id: node_id,
            pending_node_id: node_id,
            pending_bit_rate: bit_rate,
            supported_rates,
            selective: 0,
            fastscan_sub: 0,
            identify: false,
        }
    }

    /// Power-on of the slave that [`LssSlave::new`] built unconfigured
    /// (waiting, no sequence begun): its node-id, bit rate and the rates it
    /// can run at, as `new` takes them. Only these fields: the rest is
    /// already what `new` gives, and the address follows 0x1018 at the
    /// reset (four stores fewer than a whole new slave).
    pub fn power_on(&mut self, node_id: u8, bit_rate: u8, supported_rates: u16) {
        self.active_node_id = node_id;
        self.pending_node_id = node_id;
        self.pending_bit_rate = bit_rate;
        self.supported_rates = supported_rates;
    }

    /// The LSS address to replace (0x1018 sub 1..4 changed, e.g. a serial number set by the board).
    pub fn address_mut(&mut self) -> &mut [u32; 4] {
        &mut self.address
    }

    /// The LSS address (0x1018 sub 1..4).
    pub fn address(&self) -> [u32; 4] {
        self.address
    }

    /// The LSS state.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// The node-id in use (0xFF while unconfigured).
    pub fn active_node_id(&self) -> u8 {
        self.active_node_id
    }

    /// The node-id that the next reset communication takes over.
    pub fn pending_node_id(&self) -> u8 {
        self.pending_node_id
    }

    /// Reset communication: the pending node-id becomes active.
    pub fn reset_communication(&mut self) -> u8 {
        self.active_node_id = self.pending_node_id;
        self.active_node_id
    }

    /// The answer to "store configuration": 0 success, 2 storage error.
    pub fn store_result(ok: bool) -> [u8; 8] {
        answer(0x17, if ok { 0 } else { 2 }, 0)
    }

    /// Handles one request from the master (a frame of 8 bytes on 0x7E5),
    /// served as it is: the command specifier chooses, each service reads
    /// its own fields (no [`crate::wire::lss::LssRequest`] is built, whose
    /// fields would be packed only to be taken apart). What
    /// [`crate::wire::lss::LssRequest::parse`] refuses is [`LssAction::Malformed`].
    // Offsets from a range's first command specifier: 0..=3 (address parts), 0..=5 (identify bounds).
    #[allow(clippy::arithmetic_side_effects)]
    pub fn on_request(&mut self, d: &[u8; 8]) -> LssAction {
        let [cs, b1, b2, ..] = *d;
        let value = u32_at(d);
        let configuring = self.mode == Mode::Configuration;
        // A switch-state-selective sequence goes on only with its next part: any other request ends it.
        let selective = core::mem::take(&mut self.selective);
        match cs {
            // Switch state global: 1 configuration, 0 waiting.
            0x04 if b1 == 1 => {
                self.mode = Mode::Configuration;
                LssAction::None
            }
            0x04 if b1 == 0 => self.enter_waiting(),
            // Configuration services in the waiting state are ignored (CiA 305 §4.3).
            0x11 | 0x13 | 0x15 | 0x17 | 0x5A..=0x5E if !configuring => LssAction::None,
            // Switch state selective: vendor, product, revision, serial number.
            0x40..=0x43 => {
                let part = cs - 0x40;
                // The four parts come in order; anything else starts over (the vendor-id a new sequence).
                let matched = self.part(part) == value && (part == 0 || selective == part);
                self.selective = if matched { part + 1 } else { 0 };
                if self.selective < 4 {
                    return LssAction::None;
                }
                self.mode = Mode::Configuration;
                reply(0x44, 0)
            }
            // Configure node-id.
            0x11 => {
                // CiA 305 §5.2.2.2: 1..=127 or 0xFF (back to unconfigured); error 1 otherwise.
                let ok = (1..=127).contains(&b1) || b1 == UNCONFIGURED;
                if ok {
                    self.pending_node_id = b1;
                }
                reply(0x11, u8::from(!ok))
            }
            // Configure bit timing: table selector, table index.
            0x13 => {
                let supported = b1 == 0 && b2 < 16 && self.supported_rates & (1 << b2) != 0;
                if supported {
                    self.pending_bit_rate = b2;
                }
                reply(0x13, u8::from(!supported))
            }
            0x15 => LssAction::ActivateBitTiming { delay_ms: u16::from_le_bytes([b1, b2]), index: self.pending_bit_rate },
            0x17 => LssAction::Store { node_id: self.pending_node_id, bit_rate: self.pending_bit_rate },
            // Inquire vendor, product, revision, serial number: answered with the same specifier.
            0x5A..=0x5D => LssAction::Answer(LssAnswer { cs, data: self.part(cs - 0x5A) }),
            0x5E => reply(0x5E, self.active_node_id),
            // Identify remote slave: vendor, product, revision low/high, serial low/high.
            // Each bound is checked as it comes (as CANopenNode does), so no bound is kept.
            0x46..=0x4B => {
                let k = cs - 0x46;
                let mine = self.part(if k < 2 { k } else { k / 2 + 1 });
                // Vendor and product equal, then a low bound (revision, serial number) and its high bound.
                let ok = if k < 2 {
                    mine == value
                } else if k & 1 == 0 {
                    mine >= value
                } else {
                    mine <= value
                };
                self.identify = ok && (k == 0 || self.identify);
                // The serial-number high bound comes last; then the slave answers if it is in range.
                if k == 5 && self.identify { reply(0x4F, 0) } else { LssAction::None }
            }
            0x4C if self.active_node_id == UNCONFIGURED => reply(0x50, 0),
            0x4C => LssAction::None,
            0x51 => self.fastscan(value, d),
            // Not a request (CiA 305 defines no such command specifier): the sequence goes on.
            _ => {
                self.selective = selective;
                LssAction::Malformed
            }
        }
    }

    /// Address part `n` (0 vendor-id … 3 serial number; callers pass 0..=3).
    fn part(&self, n: u8) -> u32 {
        // Masked to two bits: always in the array, so no bounds check is left.
        self.address.get(usize::from(n & 3)).copied().unwrap_or(0)
    }

    fn enter_waiting(&mut self) -> LssAction {
        self.mode = Mode::Waiting;
        if self.active_node_id == UNCONFIGURED && self.pending_node_id != UNCONFIGURED {
            self.active_node_id = self.pending_node_id;
            return LssAction::Start(self.active_node_id);
        }
        LssAction::None
    }

    /// CiA 305 §5.5: only unconfigured slaves in the waiting state take part.
    fn fastscan(&mut self, id: u32, d: &[u8; 8]) -> LssAction {
        // Bytes 5..=7 read here, not with the others: only this service has them.
        let [.., bit_checked, sub, next] = *d;
        if self.active_node_id != UNCONFIGURED || self.mode != Mode::Waiting {
            return LssAction::None;
        }
        if bit_checked == 0x80 {
            self.fastscan_sub = 0;
            return reply(0x4F, 0);
        }
        // `fastscan_sub` is 0..=3, so an equal `sub` is too.
        if bit_checked > 31 || next > 3 || sub != self.fastscan_sub {
            return LssAction::None;
        }
        let mine = self.part(sub);
        // The bits from `bit_checked` up must match.
        if (mine ^ id) >> bit_checked != 0 {
            return LssAction::None;
        }
        if bit_checked == 0 {
            // The part is confirmed. After the serial number (next wraps to the
            // first part) the slave enters the configuration state.
            if next < sub {
                self.mode = Mode::Configuration;
                self.fastscan_sub = 0;
            } else {
                self.fastscan_sub = next;
            }
        }
        reply(0x4F, 0)
    }
}

#[cfg(test)]
mod tests;
