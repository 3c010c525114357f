//! The CiA 402 drive state machine (IEC 61800-7-201 §4.2 / CiA 402-2
//! Figure 1): controlword 0x6040 commands, statusword 0x6041 states, the
//! drive's transitions (for the virtual drive) and the controlword the
//! bridge sends to bring a drive to operation enabled.

/// Controlword values the bridge sends (CiA 402 Table 3).
pub mod cw {
    /// Disable voltage: bit 1 = 0 (→ switch on disabled).
    pub const DISABLE_VOLTAGE: u16 = 0x0000;
    /// Quick stop: bit 1 = 1, bit 2 = 0 (quick stop is active low).
    pub const QUICK_STOP: u16 = 0x0002;
    /// Shutdown: bits 1, 2 = 1, bit 0 = 0 (→ ready to switch on; power stage off).
    pub const SHUTDOWN: u16 = 0x0006;
    /// Switch on (also "disable operation"): bits 0–2 = 1, bit 3 = 0.
    pub const SWITCH_ON: u16 = 0x0007;
    /// Enable operation (also "switch on + enable operation"): bits 0–3 = 1.
    pub const ENABLE_OPERATION: u16 = 0x000F;
    /// Fault reset: bit 7, acting on its rising edge.
    pub const FAULT_RESET: u16 = 0x0080;
}

/// Statusword masks and values (CiA 402 Table 5).
pub mod sw {
    /// Bits 0–3 and 6: enough for the states where quick stop (bit 5) is "don't care".
    pub const MASK_SHORT: u16 = 0x004F;
    /// Bits 0–3, 5 and 6.
    pub const MASK_LONG: u16 = 0x006F;
    pub const NOT_READY_TO_SWITCH_ON: u16 = 0x0000;
    pub const SWITCH_ON_DISABLED: u16 = 0x0040;
    pub const READY_TO_SWITCH_ON: u16 = 0x0021;
    pub const SWITCHED_ON: u16 = 0x0023;
    pub const OPERATION_ENABLED: u16 = 0x0027;
    pub const QUICK_STOP_ACTIVE: u16 = 0x0007;
    pub const FAULT_REACTION_ACTIVE: u16 = 0x000F;
    pub const FAULT: u16 = 0x0008;
    /// Bit 4: the power stage has voltage.
    pub const VOLTAGE_ENABLED: u16 = 0x0010;
    /// Bit 7: a warning.
    pub const WARNING: u16 = 0x0080;
    /// Bit 9: the drive follows the controlword (remote).
    pub const REMOTE: u16 = 0x0200;
    /// Bit 10: target reached (profile velocity: the speed is the target's).
    pub const TARGET_REACHED: u16 = 0x0400;
}

/// The states of CiA 402 Figure 1.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DriveState {
    NotReadyToSwitchOn,
    SwitchOnDisabled,
    ReadyToSwitchOn,
    SwitchedOn,
    OperationEnabled,
    QuickStopActive,
    FaultReactionActive,
    Fault,
}

impl DriveState {
    /// Every state, in the order of [`code`](Self::code).
    pub const ALL: [DriveState; 8] = [
        DriveState::NotReadyToSwitchOn,
        DriveState::SwitchOnDisabled,
        DriveState::ReadyToSwitchOn,
        DriveState::SwitchedOn,
        DriveState::OperationEnabled,
        DriveState::QuickStopActive,
        DriveState::FaultReactionActive,
        DriveState::Fault,
    ];

    /// A small number for reports (`raw_state`): 0–7 in the order above.
    pub fn code(self) -> u8 {
        self as u8
    }

    /// The state bits of the statusword (CiA 402 Table 5).
    pub fn statusword_bits(self) -> u16 {
        match self {
            Self::NotReadyToSwitchOn => sw::NOT_READY_TO_SWITCH_ON,
            Self::SwitchOnDisabled => sw::SWITCH_ON_DISABLED,
            Self::ReadyToSwitchOn => sw::READY_TO_SWITCH_ON,
            Self::SwitchedOn => sw::SWITCHED_ON,
            Self::OperationEnabled => sw::OPERATION_ENABLED,
            Self::QuickStopActive => sw::QUICK_STOP_ACTIVE,
            Self::FaultReactionActive => sw::FAULT_REACTION_ACTIVE,
            Self::Fault => sw::FAULT,
        }
    }

    /// The state a statusword shows; `None` for a bit pattern Table 5 does not define.
    pub fn from_statusword(word: u16) -> Option<Self> {
        match word & sw::MASK_SHORT {
            sw::NOT_READY_TO_SWITCH_ON => return Some(Self::NotReadyToSwitchOn),
            sw::SWITCH_ON_DISABLED => return Some(Self::SwitchOnDisabled),
            sw::FAULT_REACTION_ACTIVE => return Some(Self::FaultReactionActive),
            sw::FAULT => return Some(Self::Fault),
            _ => {}
        }
        match word & sw::MASK_LONG {
            sw::READY_TO_SWITCH_ON => Some(Self::ReadyToSwitchOn),
            sw::SWITCHED_ON => Some(Self::SwitchedOn),
            sw::OPERATION_ENABLED => Some(Self::OperationEnabled),
            sw::QUICK_STOP_ACTIVE => Some(Self::QuickStopActive),
            _ => None,
        }
    }

    /// The power stage may drive the motor.
    pub fn powered(self) -> bool {
        matches!(
            self,
            Self::OperationEnabled | Self::QuickStopActive | Self::FaultReactionActive
        )
    }
}

/// A controlword command (CiA 402 Table 3), bit 7 aside.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Command {
    Shutdown,
    /// Also "disable operation" (the same bits).
    SwitchOn,
    /// Also "switch on + enable operation".
    EnableOperation,
    DisableVoltage,
    QuickStop,
    /// Bit 7 set (a fault reset when it rises).
    FaultReset,
}

/// The command a controlword encodes; `None` for a pattern Table 3 leaves undefined.
pub fn decode_controlword(word: u16) -> Option<Command> {
    if word & 0x0080 != 0 {
        return Some(Command::FaultReset);
    }
    if word & 0x0002 == 0 {
        return Some(Command::DisableVoltage); // 0xx0x
    }
    if word & 0x0004 == 0 {
        return Some(Command::QuickStop); // 0x01x
    }
    match word & 0x000F {
        0x0006 | 0x000E => Some(Command::Shutdown), // 0x110
        0x0007 => Some(Command::SwitchOn),          // 00111
        0x000F => Some(Command::EnableOperation),   // 01111
        _ => None,
    }
}

/// The drive's side: state, the transitions a controlword causes, and the
/// automatic ones (power-up, fault reaction, end of a quick stop).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DriveMachine {
    pub state: DriveState,
    last_word: u16,
}

impl Default for DriveMachine {
    fn default() -> Self {
        Self::new()
    }
}

impl DriveMachine {
    /// At power-up: not ready to switch on (transition 0).
    pub fn new() -> Self {
        Self {
            state: DriveState::NotReadyToSwitchOn,
            last_word: 0,
        }
    }

    /// Applies a received controlword; returns the CiA 402 transition number taken, if any.
    pub fn on_controlword(&mut self, word: u16) -> Option<u8> {
        use Command as C;
        use DriveState as S;
        let rising_reset = word & 0x0080 != 0 && self.last_word & 0x0080 == 0;
        self.last_word = word;
        let (next, n) = match (self.state, decode_controlword(word)?) {
            (S::SwitchOnDisabled, C::Shutdown) => (S::ReadyToSwitchOn, 2),
            (S::ReadyToSwitchOn, C::SwitchOn) => (S::SwitchedOn, 3),
            // "Switch on + enable operation": transitions 3 and 4 at once.
            (S::ReadyToSwitchOn, C::EnableOperation) => (S::OperationEnabled, 4),
            (S::SwitchedOn, C::EnableOperation) => (S::OperationEnabled, 4),
            (S::OperationEnabled, C::SwitchOn) => (S::SwitchedOn, 5),
            (S::SwitchedOn, C::Shutdown) => (S::ReadyToSwitchOn, 6),
            (S::ReadyToSwitchOn, C::QuickStop | C::DisableVoltage) => (S::SwitchOnDisabled, 7),
            (S::OperationEnabled, C::Shutdown) => (S::ReadyToSwitchOn, 8),
            (S::OperationEnabled, C::DisableVoltage) => (S::SwitchOnDisabled, 9),
            (S::SwitchedOn, C::DisableVoltage | C::QuickStop) => (S::SwitchOnDisabled, 10),
            (S::OperationEnabled, C::QuickStop) => (S::QuickStopActive, 11),
            (S::QuickStopActive, C::DisableVoltage) => (S::SwitchOnDisabled, 12),
            (S::Fault, C::FaultReset) if rising_reset => (S::SwitchOnDisabled, 15),
            _ => return None,
        };
        self.state = next;
        Some(n)
    }

    /// Automatic transitions: 1 (self-test done), 14 (fault reaction done),
    /// and 12 at standstill after a quick stop (quick stop option code 2:
    /// "slow down on the quick stop ramp, then switch on disabled").
    pub fn tick(&mut self, at_standstill: bool) -> Option<u8> {
        let (next, n) = match self.state {
            DriveState::NotReadyToSwitchOn => (DriveState::SwitchOnDisabled, 1),
            DriveState::FaultReactionActive => (DriveState::Fault, 14),
            DriveState::QuickStopActive if at_standstill => (DriveState::SwitchOnDisabled, 12),
            _ => return None,
        };
        self.state = next;
        Some(n)
    }

    /// A fault (transition 13): from any state but fault.
    pub fn fault(&mut self) -> Option<u8> {
        if matches!(self.state, DriveState::Fault | DriveState::FaultReactionActive) {
            return None;
        }
        self.state = DriveState::FaultReactionActive;
        Some(13)
    }
}

/// The controlword that moves a drive in `state` one step towards operation
/// enabled (shutdown → switch on → enable operation). Until the drive has
/// been seen in ready to switch on (`seen_ready`), a drive found switched on
/// or enabled is shut down first: every enable then follows a switch on the
/// bridge sent from a state it saw, never a stale statusword. A fault is
/// reset only when `may_reset_fault`, by a rising edge of bit 7 after a
/// word without it (`last_word`). `None` state (no statusword yet):
/// shutdown, which is harmless in every state.
pub fn enabling_controlword(state: Option<DriveState>, last_word: u16, seen_ready: bool, may_reset_fault: bool) -> u16 {
    match state {
        None | Some(DriveState::NotReadyToSwitchOn) | Some(DriveState::SwitchOnDisabled) => cw::SHUTDOWN,
        Some(DriveState::ReadyToSwitchOn) => cw::SWITCH_ON,
        Some(DriveState::SwitchedOn) | Some(DriveState::OperationEnabled) if !seen_ready => cw::SHUTDOWN,
        Some(DriveState::SwitchedOn) | Some(DriveState::OperationEnabled) => cw::ENABLE_OPERATION,
        // Out of a quick stop only through switch on disabled (transition 12).
        Some(DriveState::QuickStopActive) => cw::DISABLE_VOLTAGE,
        Some(DriveState::FaultReactionActive) => cw::DISABLE_VOLTAGE,
        Some(DriveState::Fault) if may_reset_fault && last_word & cw::FAULT_RESET == 0 => cw::FAULT_RESET,
        Some(DriveState::Fault) => cw::DISABLE_VOLTAGE,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use DriveState as S;

    // Statusword patterns by hand from CiA 402 Table 5 (x = don't care bits set
    // to 1 to show they are ignored: voltage enabled 0x10, warning 0x80,
    // remote 0x200, target reached 0x400, manufacturer 0xC000).
    #[test]
    fn statusword_decoding_with_masks_0x4f_and_0x6f() {
        let noise = 0x0010 | 0x0080 | 0x0200 | 0x0400 | 0xC000;
        let cases = [
            (0x0000, S::NotReadyToSwitchOn),
            (0x0020, S::NotReadyToSwitchOn), // bit 5 don't care
            (0x0040, S::SwitchOnDisabled),
            (0x0060, S::SwitchOnDisabled),
            (0x0021, S::ReadyToSwitchOn),
            (0x0023, S::SwitchedOn),
            (0x0027, S::OperationEnabled),
            (0x0007, S::QuickStopActive),
            (0x000F, S::FaultReactionActive),
            (0x002F, S::FaultReactionActive),
            (0x0008, S::Fault),
            (0x0028, S::Fault),
        ];
        for (word, want) in cases {
            assert_eq!(DriveState::from_statusword(word), Some(want), "0x{word:04X}");
            assert_eq!(
                DriveState::from_statusword(word | noise),
                Some(want),
                "0x{word:04X} with noise"
            );
        }
        // Patterns Table 5 does not define.
        for word in [0x0001, 0x0003, 0x0041, 0x0067, 0x0005] {
            assert_eq!(DriveState::from_statusword(word), None, "0x{word:04X}");
        }
        for s in DriveState::ALL {
            assert_eq!(DriveState::from_statusword(s.statusword_bits()), Some(s));
            assert_eq!(DriveState::ALL[usize::from(s.code())], s);
        }
    }

    #[test]
    fn controlword_commands() {
        assert_eq!(decode_controlword(0x0006), Some(Command::Shutdown));
        assert_eq!(decode_controlword(0x000E), Some(Command::Shutdown));
        assert_eq!(decode_controlword(0x0007), Some(Command::SwitchOn));
        assert_eq!(decode_controlword(0x000F), Some(Command::EnableOperation));
        assert_eq!(decode_controlword(0x0000), Some(Command::DisableVoltage));
        assert_eq!(decode_controlword(0x000D), Some(Command::DisableVoltage));
        assert_eq!(decode_controlword(0x0002), Some(Command::QuickStop));
        assert_eq!(decode_controlword(0x000B), Some(Command::QuickStop));
        assert_eq!(decode_controlword(0x0080), Some(Command::FaultReset));
        // Bits 4–6, 8 (halt) and above are mode / manufacturer specific.
        assert_eq!(decode_controlword(0x010F), Some(Command::EnableOperation));
    }

    fn at(s: DriveState) -> DriveMachine {
        let mut m = DriveMachine::new();
        m.state = s;
        m
    }

    /// Every transition of CiA 402 Figure 1 that a controlword causes.
    #[test]
    fn every_controlword_transition() {
        let cases: &[(DriveState, u16, DriveState, u8)] = &[
            (S::SwitchOnDisabled, 0x0006, S::ReadyToSwitchOn, 2),
            (S::ReadyToSwitchOn, 0x0007, S::SwitchedOn, 3),
            (S::SwitchedOn, 0x000F, S::OperationEnabled, 4),
            (S::ReadyToSwitchOn, 0x000F, S::OperationEnabled, 4),
            (S::OperationEnabled, 0x0007, S::SwitchedOn, 5),
            (S::SwitchedOn, 0x0006, S::ReadyToSwitchOn, 6),
            (S::ReadyToSwitchOn, 0x0002, S::SwitchOnDisabled, 7),
            (S::ReadyToSwitchOn, 0x0000, S::SwitchOnDisabled, 7),
            (S::OperationEnabled, 0x0006, S::ReadyToSwitchOn, 8),
            (S::OperationEnabled, 0x0000, S::SwitchOnDisabled, 9),
            (S::SwitchedOn, 0x0000, S::SwitchOnDisabled, 10),
            (S::SwitchedOn, 0x0002, S::SwitchOnDisabled, 10),
            (S::OperationEnabled, 0x0002, S::QuickStopActive, 11),
            (S::QuickStopActive, 0x0000, S::SwitchOnDisabled, 12),
            (S::Fault, 0x0080, S::SwitchOnDisabled, 15),
        ];
        for &(from, word, to, n) in cases {
            let mut m = at(from);
            assert_eq!(m.on_controlword(word), Some(n), "{from:?} + 0x{word:04X}");
            assert_eq!(m.state, to, "{from:?} + 0x{word:04X}");
        }
        // Commands that do not apply leave the state alone.
        for &(from, word) in &[
            (S::SwitchOnDisabled, 0x0007),
            (S::SwitchOnDisabled, 0x000F),
            (S::Fault, 0x000F),
            (S::Fault, 0x0006),
            (S::QuickStopActive, 0x000F),
            (S::QuickStopActive, 0x0006),
            (S::OperationEnabled, 0x0080),
        ] {
            let mut m = at(from);
            assert_eq!(m.on_controlword(word), None, "{from:?} + 0x{word:04X}");
            assert_eq!(m.state, from);
        }
    }

    #[test]
    fn fault_reset_needs_a_rising_edge() {
        let mut m = at(S::Fault);
        m.last_word = 0x0080;
        assert_eq!(m.on_controlword(0x0080), None, "bit 7 held high is no edge");
        assert_eq!(m.state, S::Fault);
        m.on_controlword(0x0000);
        assert_eq!(m.on_controlword(0x0080), Some(15));
        assert_eq!(m.state, S::SwitchOnDisabled);
    }

    #[test]
    fn automatic_transitions_and_faults() {
        let mut m = DriveMachine::new();
        assert_eq!(m.state, S::NotReadyToSwitchOn);
        assert_eq!(m.tick(true), Some(1));
        assert_eq!(m.state, S::SwitchOnDisabled);
        assert_eq!(m.tick(true), None);
        let mut m = at(S::OperationEnabled);
        assert_eq!(m.fault(), Some(13));
        assert_eq!(m.state, S::FaultReactionActive);
        assert_eq!(m.fault(), None);
        assert_eq!(m.tick(false), Some(14));
        assert_eq!(m.state, S::Fault);
        let mut m = at(S::QuickStopActive);
        assert_eq!(m.tick(false), None, "still braking");
        assert_eq!(m.tick(true), Some(12));
        assert_eq!(m.state, S::SwitchOnDisabled);
        assert!(S::OperationEnabled.powered() && S::QuickStopActive.powered());
        assert!(!S::SwitchedOn.powered() && !S::Fault.powered());
    }

    /// The bridge's sequence, run against the drive's machine: from every
    /// state it reaches operation enabled (faults only when allowed), one
    /// step per word, and never sends enable operation before switch on.
    #[test]
    fn enabling_sequence_reaches_operation_enabled_from_every_state() {
        for start in DriveState::ALL {
            let mut m = at(start);
            let mut last = 0x0000;
            let mut seen_ready = false;
            let mut words = Vec::new();
            for _ in 0..10 {
                m.tick(true);
                seen_ready |= m.state == S::ReadyToSwitchOn;
                let w = enabling_controlword(Some(m.state), last, seen_ready, true);
                words.push(w);
                m.on_controlword(w);
                last = w;
                if m.state == S::OperationEnabled {
                    break;
                }
            }
            assert_eq!(m.state, S::OperationEnabled, "from {start:?}: {words:04X?}");
            // Every start, even switched on or enabled: (shutdown,) switch on, then enable.
            let i = words.iter().position(|w| *w == cw::ENABLE_OPERATION).unwrap();
            let on = words[..i]
                .iter()
                .rposition(|w| *w == cw::SWITCH_ON)
                .expect("switch on first");
            assert!(
                start == S::ReadyToSwitchOn || words[..on].contains(&cw::SHUTDOWN),
                "from {start:?}: {words:04X?}"
            );
        }
        // Found enabled (a restart): shut down first, not kept enabled.
        assert_eq!(
            enabling_controlword(Some(S::OperationEnabled), 0x000F, false, true),
            0x0006
        );
        assert_eq!(enabling_controlword(Some(S::SwitchedOn), 0x0006, false, true), 0x0006);
        assert_eq!(enabling_controlword(Some(S::SwitchedOn), 0x0007, true, true), 0x000F);
        // A fault that may not be reset stays: the word never has bit 7.
        let mut m = at(S::Fault);
        for _ in 0..5 {
            let w = enabling_controlword(Some(m.state), 0, true, false);
            assert_eq!(w & cw::FAULT_RESET, 0);
            m.on_controlword(w);
        }
        assert_eq!(m.state, S::Fault);
        // Without a statusword: shutdown (harmless everywhere).
        assert_eq!(enabling_controlword(None, 0, false, true), 0x0006);
        // Bit 7 alternates so every reset is a new edge.
        assert_eq!(enabling_controlword(Some(S::Fault), 0x0080, false, true), 0x0000);
        assert_eq!(enabling_controlword(Some(S::Fault), 0x0000, false, true), 0x0080);
    }
}
