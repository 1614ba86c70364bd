//! Compact body states for the protobuf tick stream (`Subscribe.compact`): f32 offsets from a
//! per-frame origin and "smallest three" quaternions in 62 bits. The encoding and its error
//! bounds are specified in `proto/swell/v1/stream.proto` (`CompactBodyState`); [`decode`] is the
//! reference decoder clients can port.

use crate::service::types::BodyState;
use crate::wire::v1;

/// Bits per quantised quaternion component.
const ROT_BITS: u32 = 20;
/// Quantisation half-range: a component `c` is stored as `round(c·√2·H) + H`, in `0..=2H`
/// (20 bits), so zero is exact.
const ROT_HALF: f64 = ((1u64 << (ROT_BITS - 1)) - 1) as f64;

/// The frame's origin: the centre of the bodies' bounding box, rounded to whole metres (zero
/// without bodies or with a non-finite position, which the frame's finite check refuses anyway).
pub fn origin(bodies: &[BodyState]) -> [f64; 3] {
    let mut out = [0.0; 3];
    if bodies.is_empty() {
        return out;
    }
    for (k, o) in out.iter_mut().enumerate() {
        let (lo, hi) = bodies
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), b| {
                (lo.min(b.position[k]), hi.max(b.position[k]))
            });
        let c = (0.5 * lo + 0.5 * hi).round();
        *o = if c.is_finite() { c } else { 0.0 };
    }
    out
}

/// `q` (x, y, z, w; unit length) packed as smallest three (see the proto).
pub fn pack_rotation(q: [f64; 4]) -> u64 {
    let mut big = 0;
    for i in 1..4 {
        if q[i].abs() > q[big].abs() {
            big = i;
        }
    }
    // q and −q are the same rotation: make the dropped component positive.
    let sign = if q[big] < 0.0 { -1.0 } else { 1.0 };
    let mut packed = (big as u64) << (3 * ROT_BITS);
    let mut shift = 2 * ROT_BITS;
    for (i, c) in q.iter().enumerate() {
        if i == big {
            continue;
        }
        let v = ((sign * c * std::f64::consts::SQRT_2 * ROT_HALF).round() + ROT_HALF)
            .clamp(0.0, 2.0 * ROT_HALF) as u64;
        packed |= v << shift;
        shift = shift.saturating_sub(ROT_BITS);
    }
    packed
}

/// The unit quaternion (x, y, z, w) of a packed rotation.
pub fn unpack_rotation(packed: u64) -> [f64; 4] {
    let big = ((packed >> (3 * ROT_BITS)) & 3) as usize;
    let mask = (1u64 << ROT_BITS) - 1;
    let mut q = [0.0; 4];
    let mut shift = 2 * ROT_BITS;
    let mut sum = 0.0;
    for (i, c) in q.iter_mut().enumerate() {
        if i == big {
            continue;
        }
        let v = ((packed >> shift) & mask) as f64;
        *c = (v - ROT_HALF) / ROT_HALF / std::f64::consts::SQRT_2;
        sum += *c * *c;
        shift = shift.saturating_sub(ROT_BITS);
    }
    q[big] = (1.0 - sum).max(0.0).sqrt();
    q
}

/// `b` in compact form against `origin`.
pub fn encode(b: &BodyState, origin: [f64; 3]) -> v1::CompactBodyState {
    let f32s = |v: [f64; 3]| v.iter().map(|&x| x as f32).collect::<Vec<f32>>();
    v1::CompactBodyState {
        id: b.id,
        position: (0..3).map(|k| (b.position[k] - origin[k]) as f32).collect(),
        rotation: pack_rotation(b.rotation),
        velocity: f32s(b.velocity),
        angular_velocity: f32s(b.angular_velocity),
        submerged: b.submerged as f32,
        quarantined: b.quarantined,
    }
}

/// The reference decoder: the state a client reads from a compact body and its frame's origin.
/// `None` if a vector does not have three components.
pub fn decode(c: &v1::CompactBodyState, origin: [f64; 3]) -> Option<BodyState> {
    let v3 = |v: &[f32]| -> Option<[f64; 3]> {
        match v {
            [x, y, z] => Some([f64::from(*x), f64::from(*y), f64::from(*z)]),
            _ => None,
        }
    };
    let p = v3(&c.position)?;
    Some(BodyState {
        id: c.id,
        position: [p[0] + origin[0], p[1] + origin[1], p[2] + origin[2]],
        rotation: unpack_rotation(c.rotation),
        velocity: v3(&c.velocity)?,
        angular_velocity: v3(&c.angular_velocity)?,
        submerged: f64::from(c.submerged),
        quarantined: c.quarantined,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small seeded generator (SplitMix64): the test needs no RNG crate.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^= z >> 31;
            (z >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        }
    }

    fn unit(q: [f64; 4]) -> [f64; 4] {
        let n = q.iter().map(|c| c * c).sum::<f64>().sqrt();
        q.map(|c| c / n)
    }

    /// The angle of the rotation between unit quaternions a and b, rad.
    fn angle(a: [f64; 4], b: [f64; 4]) -> f64 {
        let d: f64 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
        2.0 * d.abs().min(1.0).acos()
    }

    #[test]
    fn rotations_round_trip_within_the_documented_bound() {
        let mut rng = Rng(7);
        let mut worst: f64 = 0.0;
        let mut worst_component: f64 = 0.0;
        let mut worst_kept: f64 = 0.0;
        for n in 0..100_000 {
            let q = if n < 8 {
                // The axes and their negatives: the dropped component is exactly ±1.
                let mut q = [0.0; 4];
                q[n % 4] = if n < 4 { 1.0 } else { -1.0 };
                q
            } else {
                unit([rng.next(), rng.next(), rng.next(), rng.next()])
            };
            let r = unpack_rotation(pack_rotation(q));
            let s = if q.iter().zip(&r).map(|(a, b)| a * b).sum::<f64>() < 0.0 {
                -1.0
            } else {
                1.0
            };
            let big = (0..4).fold(0, |b, k| if q[k].abs() > q[b].abs() { k } else { b });
            for k in 0..4 {
                let e = (q[k] * s - r[k]).abs();
                worst_component = worst_component.max(e);
                if k != big {
                    worst_kept = worst_kept.max(e);
                }
            }
            worst = worst.max(angle(q, r));
        }
        assert!(
            worst_component < 2.1e-6,
            "component error {worst_component}"
        );
        assert!(worst_kept < 6.8e-7, "kept component error {worst_kept}");
        assert!(worst < 5e-6, "angle error {worst} rad");
        // And it is not trivially zero: 20 bits do lose something.
        assert!(worst > 1e-8);
    }

    #[test]
    fn positions_are_offsets_from_the_rounded_centre() {
        let mut b = BodyState {
            id: 3,
            position: [1000.25, -0.5, -2000.125],
            rotation: [0.0, 0.0, 0.0, 1.0],
            velocity: [1.0 / 3.0, 0.0, -2.0],
            angular_velocity: [0.0, 0.1, 0.0],
            submerged: 0.4,
            quarantined: false,
        };
        let other = BodyState {
            position: [1100.0, 0.0, -1900.0],
            ..b
        };
        let o = origin(&[b, other]);
        assert_eq!(o, [1050.0, 0.0, -1950.0]);
        b.position[0] += 1e-3;
        let d = decode(&encode(&b, o), o).unwrap();
        for (k, ok) in o.iter().enumerate() {
            let bound = (b.position[k] - ok).abs() * f64::from(f32::EPSILON) * 0.5;
            assert!((d.position[k] - b.position[k]).abs() <= bound, "{k}");
            let vb = b.velocity[k].abs() * f64::from(f32::EPSILON) * 0.5;
            assert!((d.velocity[k] - b.velocity[k]).abs() <= vb, "{k}");
        }
        assert_eq!(d.rotation, [0.0, 0.0, 0.0, 1.0]);
        assert_eq!((d.id, d.quarantined), (3, false));
        assert!(decode(&v1::CompactBodyState::default(), o).is_none());
    }
}
