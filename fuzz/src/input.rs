//! Structured values from fuzz bytes, biased towards the values that break
//! numeric code (NaN, ±inf, ±0, extremes, subnormals).

use arbitrary::{Result, Unstructured};

/// An f64 that is special about half the time, else a raw bit pattern or a
/// small plain number (in [-32.768, 32.767]).
pub fn f64_of(u: &mut Unstructured<'_>) -> Result<f64> {
    Ok(match u.arbitrary::<u8>()? % 16 {
        0 => f64::NAN,
        1 => f64::INFINITY,
        2 => f64::NEG_INFINITY,
        3 => 0.0,
        4 => -0.0,
        5 => f64::MAX,
        6 => f64::MIN,
        7 => f64::MIN_POSITIVE,
        8 => 5e-324,
        9 => 1e300,
        10 => -1e-300,
        11 => f64::from_bits(u.arbitrary::<u64>()?),
        _ => f64::from(u.arbitrary::<i16>()?) / 1000.0,
    })
}

/// An f32 drawn as [`f64_of`] (values outside f32 become ±inf).
pub fn f32_of(u: &mut Unstructured<'_>) -> Result<f32> {
    Ok(match u.arbitrary::<u8>()? % 8 {
        0 => f32::from_bits(u.arbitrary::<u32>()?),
        1 => f32::MIN_POSITIVE,
        2 => f32::MAX,
        _ => f64_of(u)? as f32,
    })
}
