//! [`AxisDrive`]: a device's drive built on the axis model writes only
//! what it changes (its fault codes, its own monitoring); every other
//! [`Drive`] method forwards to the [`Axis`] inside.

use super::Axis;
use crate::profiles::cia402::drive::{Drive, SetPoint, Switches};
use crate::wire::emcy::EmcyCode;

/// A drive around an [`Axis`]: implement [`AxisDrive::axis`] and
/// [`AxisDrive::axis_mut`], override what differs, and the type is a
/// [`Drive`]. Each method is the [`Drive`] method of the same name; the
/// defaults forward to the axis.
///
/// A module that has both traits in scope calls these through the trait
/// (`AxisDrive::fault(self)`), as the names are the same.
pub trait AxisDrive {
    /// The axis model inside.
    fn axis(&self) -> &Axis;
    /// The axis model inside, to command it.
    fn axis_mut(&mut self) -> &mut Axis;

    /// [`Drive::reset`].
    fn reset(&mut self) {
        self.axis_mut().reset();
    }
    /// [`Drive::enable`].
    fn enable(&mut self, on: bool) {
        self.axis_mut().enable(on);
    }
    /// [`Drive::command`].
    fn command(&mut self, set_point: SetPoint) {
        self.axis_mut().command(set_point);
    }
    /// [`Drive::tick`].
    fn tick(&mut self) {
        self.axis_mut().tick();
    }
    /// [`Drive::position`].
    fn position(&self) -> i64 {
        self.axis().position()
    }
    /// [`Drive::set_position`].
    fn set_position(&mut self, position: i64) {
        self.axis_mut().set_position(position);
    }
    /// [`Drive::velocity`].
    fn velocity(&self) -> i32 {
        self.axis().velocity()
    }
    /// [`Drive::torque`].
    fn torque(&self) -> i16 {
        self.axis().torque()
    }
    /// [`Drive::temperature`].
    fn temperature(&self) -> i16 {
        self.axis().temperature()
    }
    /// [`Drive::dc_link_mv`].
    fn dc_link_mv(&self) -> u32 {
        self.axis().dc_link_mv()
    }
    /// [`Drive::fault`].
    fn fault(&self) -> EmcyCode {
        self.axis().fault()
    }
    /// [`Drive::fault_info`].
    fn fault_info(&self) -> [u8; 5] {
        self.axis().fault_info()
    }
    /// [`Drive::warning`].
    fn warning(&self) -> bool {
        self.axis().warning()
    }
    /// [`Drive::velocity_window`].
    fn velocity_window(&self) -> Option<u32> {
        self.axis().velocity_window()
    }
    /// [`Drive::status_bits`].
    fn status_bits(&self, word: u16) -> u16 {
        self.axis().status_bits(word)
    }
    /// [`Drive::reset_fault`].
    fn reset_fault(&mut self) -> bool {
        self.axis_mut().reset_fault()
    }
    /// [`Drive::switches`].
    fn switches(&self) -> Switches {
        self.axis().switches()
    }
    /// [`Drive::max_acceleration`].
    fn max_acceleration(&self) -> u32 {
        self.axis().max_acceleration()
    }
    /// [`Drive::max_velocity`].
    fn max_velocity(&self) -> u32 {
        self.axis().max_velocity()
    }
    /// [`Drive::min_velocity`].
    fn min_velocity(&self) -> u32 {
        self.axis().min_velocity()
    }
    /// [`Drive::at_rest`].
    fn at_rest(&self) -> bool {
        self.axis().at_rest()
    }
}

impl<T: AxisDrive> Drive for T {
    fn reset(&mut self) {
        AxisDrive::reset(self);
    }
    fn enable(&mut self, on: bool) {
        AxisDrive::enable(self, on);
    }
    fn command(&mut self, set_point: SetPoint) {
        AxisDrive::command(self, set_point);
    }
    fn tick(&mut self) {
        AxisDrive::tick(self);
    }
    fn position(&self) -> i64 {
        AxisDrive::position(self)
    }
    fn set_position(&mut self, position: i64) {
        AxisDrive::set_position(self, position);
    }
    fn velocity(&self) -> i32 {
        AxisDrive::velocity(self)
    }
    fn torque(&self) -> i16 {
        AxisDrive::torque(self)
    }
    fn temperature(&self) -> i16 {
        AxisDrive::temperature(self)
    }
    fn dc_link_mv(&self) -> u32 {
        AxisDrive::dc_link_mv(self)
    }
    fn fault(&self) -> EmcyCode {
        AxisDrive::fault(self)
    }
    fn fault_info(&self) -> [u8; 5] {
        AxisDrive::fault_info(self)
    }
    fn warning(&self) -> bool {
        AxisDrive::warning(self)
    }
    fn velocity_window(&self) -> Option<u32> {
        AxisDrive::velocity_window(self)
    }
    fn status_bits(&self, word: u16) -> u16 {
        AxisDrive::status_bits(self, word)
    }
    fn reset_fault(&mut self) -> bool {
        AxisDrive::reset_fault(self)
    }
    fn switches(&self) -> Switches {
        AxisDrive::switches(self)
    }
    fn max_acceleration(&self) -> u32 {
        AxisDrive::max_acceleration(self)
    }
    fn max_velocity(&self) -> u32 {
        AxisDrive::max_velocity(self)
    }
    fn min_velocity(&self) -> u32 {
        AxisDrive::min_velocity(self)
    }
    fn at_rest(&self) -> bool {
        AxisDrive::at_rest(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::axis::{AxisParams, Injected, fault};

    /// Changes one method: the fault code of a power stage fault.
    struct Renamed(Axis);

    impl AxisDrive for Renamed {
        fn axis(&self) -> &Axis {
            &self.0
        }
        fn axis_mut(&mut self) -> &mut Axis {
            &mut self.0
        }
        fn fault(&self) -> EmcyCode {
            match self.0.fault() {
                fault::POWER_STAGE => EmcyCode(0xFF15),
                code => code,
            }
        }
    }

    fn drive<D: Drive>(d: &mut D) -> (EmcyCode, bool, i32) {
        d.enable(true);
        d.command(SetPoint::Velocity(1000));
        for _ in 0..100 {
            d.tick();
        }
        (d.fault(), d.reset_fault(), d.velocity())
    }

    #[test]
    fn a_drive_on_the_axis_forwards_what_it_does_not_change() {
        let params = AxisParams { max_acceleration: 100_000, max_velocity: 10_000, ..AxisParams::ZERO };
        let (mut axis, mut renamed) = (Axis::NEW, Renamed(Axis::NEW));
        axis.configure(params);
        renamed.0.configure(params);
        // The same motion through the trait as on the bare axis.
        assert_eq!(drive(&mut renamed), drive(&mut axis));
        assert_eq!(Drive::velocity(&renamed), 1000);
        // The one method it changes.
        renamed.0.inject(Injected::PowerStage);
        assert_eq!(Drive::fault(&renamed), EmcyCode(0xFF15));
        axis.inject(Injected::PowerStage);
        assert_eq!(Drive::fault(&axis), fault::POWER_STAGE);
    }
}
