//! The hard constraints as one ordered list of relaxations (ALGORITHM.md
//! §5c). A candidate command belongs to a level when its predicted h(k+1)
//! meets that level's requirement; §5b's braking check applies at every
//! level. The selector takes the first level that has a candidate passing
//! the braking check; each level has its own infeasibility code.
//!
//! 1. [`Tier::Margin`]: §5's condition on h − δ (the noise margin), or
//!    inside the margin band at most 1 mm closer a step, not below 0.9δ:
//!    outside the unsafe set only; no closer than that allows at h averaged
//!    over recent steps either ([`super::h_mean`]).
//! 2. [`Tier::Condition`]: §5's condition itself, h(k+1) ≥ (1 − γ) h(k).
//! 3. [`Tier::Escape`]: inside the unsafe set, h rises by at least ε (or,
//!    while h falls faster than the predictions explain, by half the best
//!    rise the window offers: something the tracker missed walks in).
//! 4. [`Tier::LeastBad`]: the highest h(k+1) there is.
//! 5. [`Tier::Brake`]: no candidate passes the braking check: brake
//!    towards rest at the braking check's deceleration, which the window
//!    always holds.

use super::h_mean::allowed_approach;
use crate::algo::dtcbf::condition_target;
use crate::algo::params::Params;
use crate::algo::record::Infeasibility;
use serde::Serialize;
use std::fmt;

/// A level of the relaxation order, strictest first.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Tier {
    /// The condition with the noise margin.
    Margin,
    /// The condition of the definition.
    Condition,
    /// Inside the unsafe set: h rises.
    Escape,
    /// The highest h(k+1) available.
    LeastBad,
    /// Nothing passes the braking check: brake towards rest.
    Brake,
}

impl Tier {
    /// Every level, in the order they are relaxed.
    pub const ORDER: [Tier; 5] = [Tier::Margin, Tier::Condition, Tier::Escape, Tier::LeastBad, Tier::Brake];

    /// Short machine-readable name (CSV `tier` column, `~state`).
    pub fn code(&self) -> &'static str {
        match self {
            Self::Margin => "margin",
            Self::Condition => "condition",
            Self::Escape => "escape",
            Self::LeastBad => "least_bad",
            Self::Brake => "brake",
        }
    }

    /// Stable small integer for messages (margin 0 … brake 4).
    pub fn index(&self) -> u8 {
        *self as u8
    }

    /// Whether this level applies at h(k) = `h_m`: the margin only outside
    /// the unsafe set, escape only inside it.
    pub fn applies(&self, h_m: f64) -> bool {
        match self {
            Self::Margin => h_m >= 0.0,
            Self::Escape => h_m < 0.0,
            _ => true,
        }
    }

    /// The requirement on h(k+1) at this level (m), or `None` for the
    /// levels that have none (least-bad, brake). `mean_m` is h averaged over
    /// recent steps ([`super::h_mean`]): the margin level lets h come closer
    /// only by what it allows there too. `escape_target_m`
    /// is the escape level's, which depends on the step ([`escape_target`]).
    pub fn target(&self, h_m: f64, mean_m: f64, escape_target_m: f64, p: &Params) -> Option<f64> {
        let gamma = p.dtcbf.gamma;
        match self {
            Self::Margin => Some(h_m - allowed_approach(h_m, mean_m, gamma, p.dtcbf.noise_margin_m)),
            Self::Condition => Some(condition_target(h_m, gamma)),
            Self::Escape => Some(escape_target_m),
            Self::LeastBad | Self::Brake => None,
        }
    }

    /// What the record reports when the command comes from this level at
    /// h(k) = `h_m`: nothing at the two levels that meet the condition; the
    /// unsafe set or an approaching obstacle below them; no passive command
    /// when nothing passes the braking check.
    pub fn infeasibility(&self, h_m: f64) -> Option<Infeasibility> {
        match self {
            Self::Margin | Self::Condition => None,
            Self::Escape => Some(Infeasibility::UnsafeSet),
            Self::LeastBad if h_m < 0.0 => Some(Infeasibility::UnsafeSet),
            Self::LeastBad => Some(Infeasibility::Approaching),
            Self::Brake => Some(Infeasibility::NoPassiveCommand),
        }
    }
}

impl fmt::Display for Tier {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.code())
    }
}

/// Inside the unsafe set, when the condition's rise γ|h| is out of reach,
/// the share of the best rise of h the window offers that an escape must
/// reach while h falls faster than the predictions explain (the filter's
/// "closing in"): rather than a crawl something unseen outpaces.
pub const ESCAPE_BEST_SHARE: f64 = 0.5;

/// The escape level's requirement on h(k+1) (m): a rise of ε, or, while
/// something closes in unexplained, [`ESCAPE_BEST_SHARE`] of the best rise
/// `best_h_next_m` available, whichever is more.
pub fn escape_target(h_m: f64, best_h_next_m: f64, closing_in: bool, p: &Params) -> f64 {
    let least = h_m + p.dtcbf.escape_epsilon_m;
    if closing_in && best_h_next_m.is_finite() {
        least.max(h_m + ESCAPE_BEST_SHARE * (best_h_next_m - h_m))
    } else {
        least
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn targets_by_hand() {
        // γ = 0.2, δ = 0.03, ε = 0.001.
        let p = Params::default();
        // h = 0.1: margin 0.8·0.07 + 0.03 = 0.086; condition 0.08.
        assert!((Tier::Margin.target(0.1, 0.1, 0.0, &p).unwrap() - 0.086).abs() < 1e-12);
        assert!((Tier::Condition.target(0.1, 0.1, 0.0, &p).unwrap() - 0.08).abs() < 1e-12);
        // h = 0.029, inside the margin band (0.8·(−0.001) + 0.03 = 0.0292 would ask h to
        // rise): 1 mm closer at most, 0.028 (above the condition's 0.0232); h = 0.0275:
        // down to the floor 0.9δ = 0.027; h = 0.02, below the floor: no closer.
        assert!((Tier::Margin.target(0.029, 0.029, 0.0, &p).unwrap() - 0.028).abs() < 1e-12);
        assert!((Tier::Margin.target(0.0275, 0.0275, 0.0, &p).unwrap() - 0.027).abs() < 1e-12);
        assert!((Tier::Margin.target(0.02, 0.02, 0.0, &p).unwrap() - 0.02).abs() < 1e-12);
        // h = −0.05: the condition asks a rise of γ|h| = 0.01; escape ε, or half the best rise.
        assert!((Tier::Condition.target(-0.05, -0.05, 0.0, &p).unwrap() + 0.04).abs() < 1e-12);
        assert!((escape_target(-0.05, 0.05, false, &p) + 0.049).abs() < 1e-12);
        assert!((escape_target(-0.05, 0.05, true, &p) - 0.0).abs() < 1e-12);
        assert!(!Tier::Margin.applies(-0.05) && Tier::Escape.applies(-0.05) && !Tier::Escape.applies(0.0));
        assert_eq!(Tier::LeastBad.target(0.1, 0.1, 0.0, &p), None);
    }

    #[test]
    fn each_level_reports_its_infeasibility() {
        assert_eq!(Tier::Margin.infeasibility(0.1), None);
        assert_eq!(Tier::Condition.infeasibility(-0.1), None);
        assert_eq!(Tier::Escape.infeasibility(-0.1), Some(Infeasibility::UnsafeSet));
        assert_eq!(Tier::LeastBad.infeasibility(0.1), Some(Infeasibility::Approaching));
        assert_eq!(Tier::LeastBad.infeasibility(-0.1), Some(Infeasibility::UnsafeSet));
        assert_eq!(Tier::Brake.infeasibility(0.1), Some(Infeasibility::NoPassiveCommand));
        let codes: Vec<_> = Tier::ORDER.iter().map(Tier::code).collect();
        assert_eq!(codes, ["margin", "condition", "escape", "least_bad", "brake"]);
    }
}
