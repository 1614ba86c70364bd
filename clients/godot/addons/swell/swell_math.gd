extends RefCounted
## Deterministic phase reduction, as the server's model does it (swell-waves phase.rs), in
## GDScript's 64-bit floats. Each operation is a separate Variant operation, so nothing can fuse
## a*b+c: the results are the server's bits on every platform Godot runs on (checked against
## GET /v1/scenes/{id}/uniforms by tests/run_tests.gd).

## 2π, and its Cody–Waite pieces of 21 significant bits: TAU1 + TAU2 + TAU3 + TAU4 = 2π to
## ~2⁻¹²⁰, so x − n·2π loses nothing for |x| < 2.7·10¹⁰ rad.
const TAU_F64 := 6.283185307179586
const INV_TAU := 0.15915494309189535
const TAU1 := 6.283184051513672
const TAU2 := 1.2556656656670384e-6
const TAU3 := 2.489347703665823e-13
const TAU4 := 1.1650928224373424e-19
## 2⁵²: adding and subtracting it rounds a double to an integer (round-to-nearest-even).
const TWO52 := 4503599627370496.0


## Whether the sign bit of x is set (true for -0.0).
static func sign_bit(x: float) -> bool:
	if x != 0.0:
		return x < 0.0
	return (PackedFloat64Array([x]).to_byte_array()[7] & 0x80) != 0


## |v| with the sign of s (Rust's f64::copysign).
static func copysign(v: float, s: float) -> float:
	var a := absf(v)
	return -a if sign_bit(s) else a


## Nearest integer, ties away from zero, sign kept (phase.rs round_ties_away).
static func round_ties_away(x: float) -> float:
	var c := copysign(TWO52, x)
	var r := (x + c) - c
	var d := x - r
	var half := copysign(0.5, x)
	if d == half:
		r = r + 2.0 * half
	if absf(x) >= TWO52:
		r = x
	return copysign(r, x)


## A phase (rad) reduced to [−π, π]: x − 2π·round(x/2π), 2π in four pieces.
static func reduce_phase(x: float) -> float:
	var n := round_ties_away(x * INV_TAU)
	var a := x - n * TAU1
	var b := a - n * TAU2
	var c := b - n * TAU3
	return c - n * TAU4
