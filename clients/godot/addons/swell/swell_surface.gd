extends RefCounted
## A scene's frame uniforms for its .gdshaderinc, computed in double precision: every sine and
## Gerstner wave's phase offset wrap(k·(d·o) − ω·t + φ) at the render origin o, and each FFT
## layer's grid offset ((o mod L)·N/L per axis). Equal to GET /v1/scenes/{id}/uniforms, bit for
## bit in f64 (tests/run_tests.gd checks it against a real server).
##
## Particle layers (harbour) have uniforms this client does not compute (ambient particles and
## impact rings): `local` is false for them, and SwellOcean takes the block from
## GET …/uniforms instead.

const SwellMath := preload("swell_math.gd")

## Per sine/Gerstner wave: [k, ω, φ, dx, dz].
var waves: Array = []
## Per FFT layer: [tile_size, resolution].
var ffts: Array = []
## Whether every layer's uniforms are computed here (no particle layer).
var local: bool = true


## From GET /v1/scenes/{id} (the whole answer, or its "derived"): Surface.new(scene).
func _init(scene: Dictionary = {}) -> void:
	var derived: Dictionary = scene.get("derived", scene)
	for layer in derived.get("layers", []):
		match layer.get("kind", ""):
			"sine", "gerstner":
				for w in layer.get("waves", []):
					waves.append([float(w.wavenumber), float(w.omega), float(w.phase), float(w.direction[0]), float(w.direction[1])])
			"fft":
				ffts.append([float(layer.tile_size), float(layer.resolution)])
			_:
				local = false


## (x mod l)·n/l, Rust's rem_euclid then ·n/l, in that order.
static func _grid(x: float, l: float, n: float) -> float:
	var r := fmod(x, l)
	if r < 0.0:
		r += l
	var v := (r * n) / l
	return 0.0 if v >= n else v


## Phase offsets (f64) at scene time t and render origin (ox, oz).
func phases(t: float, ox: float, oz: float) -> PackedFloat64Array:
	var out := PackedFloat64Array()
	for w in waves:
		var along: float = w[3] * ox + w[4] * oz
		var ph: float = w[0] * along
		ph = ph - w[1] * t
		ph = ph + w[2]
		out.append(SwellMath.reduce_phase(ph))
	return out


## The uniform block (as the server's `block`): phases as f32 padded to 4·max(1, ⌈n/4⌉), then
## one vec4 per FFT layer. Returns {"phases": PackedFloat64Array, "block": PackedFloat32Array}.
func uniforms(t: float, ox: float, oz: float) -> Dictionary:
	var ph := phases(t, ox, oz)
	var slots := 4 * maxi(1, (ph.size() + 3) / 4)
	var block := PackedFloat32Array()
	block.resize(slots + 4 * ffts.size())
	block.fill(0.0)
	for i in ph.size():
		block[i] = ph[i]
	for f in ffts.size():
		block[slots + 4 * f] = _grid(ox, ffts[f][0], ffts[f][1])
		block[slots + 4 * f + 1] = _grid(oz, ffts[f][0], ffts[f][1])
	return {"phases": ph, "block": block}
