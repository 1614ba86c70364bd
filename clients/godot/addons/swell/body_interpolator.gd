extends RefCounted
## Body-state interpolation by the JS client's rules (clients/js/src/interp.js): render bodies at
## server time minus a delay, between the two tick frames around that time. Beyond the newest
## frame the state is extrapolated along its velocity for at most `max_extrapolation` seconds
## and flagged; before the oldest it is held and flagged.
##
## Frames are the stream's `tick` messages as parsed JSON: {tick, t, bodies: [{id, position:
## [x, y, z], rotation: [x, y, z, w], velocity?: [x, y, z]}]}. States come back as Dictionaries
## {id, t, mode, tick, position: Vector3, rotation: Quaternion} (f64 maths throughout; the
## Vector3/Quaternion are only the last step, f32 in a standard Godot build).

## Seconds behind server time to render (default 0.1 = 3 ticks at 30 Hz).
var delay: float = 0.1
## Frames kept.
var capacity: int = 64
## Longest extrapolation past the newest frame, s.
var max_extrapolation: float = 0.25
var frames: Array = []


func _init(p_delay: float = 0.1, p_capacity: int = 64, p_max_extrapolation: float = 0.25) -> void:
	delay = p_delay
	capacity = p_capacity
	max_extrapolation = p_max_extrapolation


## Spherical interpolation between unit quaternions [x, y, z, w] (shortest arc), in f64.
static func slerp(a: Array, b: Array, u: float) -> Array:
	var dot: float = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]
	var bb: Array = b
	if dot < 0.0:
		dot = -dot
		bb = [-b[0], -b[1], -b[2], -b[3]]
	if dot > 0.9995:
		var q: Array = []
		for i in 4:
			q.append(a[i] + (bb[i] - a[i]) * u)
		var n := sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
		return [q[0] / n, q[1] / n, q[2] / n, q[3] / n]
	var th := acos(dot)
	var s := sin(th)
	var wa := sin((1.0 - u) * th) / s
	var wb := sin(u * th) / s
	return [wa * a[0] + wb * bb[0], wa * a[1] + wb * bb[1], wa * a[2] + wb * bb[2], wa * a[3] + wb * bb[3]]


## Adds a tick frame. A frame older than the newest (the clock ran back or seeked) resets.
func push(frame: Dictionary) -> void:
	if not frames.is_empty():
		var last: Dictionary = frames[frames.size() - 1]
		if frame.t <= last.t:
			if frame.t == last.t:
				return
			frames.clear()
	var by_id := {}
	for b in frame.get("bodies", []):
		by_id[int(b.id)] = b
	frames.append({"tick": frame.tick, "t": float(frame.t), "bodies": frame.get("bodies", []), "by_id": by_id})
	if frames.size() > capacity:
		frames.pop_front()


## The frame of tick `tick`, if still buffered (else null).
func frame_at(tick: int):
	for f in frames:
		if int(f.tick) == tick:
			return f
	return null


## States at server_time − delay.
func at(server_time: float) -> Dictionary:
	return sample(server_time - delay)


static func _state(id: int, t: float, mode: String, tick, position: Array, rotation: Array) -> Dictionary:
	return {
		"id": id, "t": t, "mode": mode, "tick": tick,
		"position_f64": position, "rotation_f64": rotation,
		"position": Vector3(position[0], position[1], position[2]),
		"rotation": Quaternion(rotation[0], rotation[1], rotation[2], rotation[3]),
	}


## Every body's state at scene time `t`: id → state, where mode is "interpolated",
## "extrapolated" (past the newest frame, ≤ max_extrapolation) or "held" (past that bound, or
## before the oldest frame): anything but "interpolated" is a flag.
func sample(t: float) -> Dictionary:
	var out := {}
	if frames.is_empty():
		return out
	var newest: Dictionary = frames[frames.size() - 1]
	if t >= newest.t:
		var dt := minf(t - newest.t, max_extrapolation)
		var mode := "held"
		if t - newest.t <= max_extrapolation:
			mode = "interpolated" if t == newest.t else "extrapolated"
		for b in newest.bodies:
			var v: Array = b.get("velocity", [0.0, 0.0, 0.0])
			var p: Array = [b.position[0] + v[0] * dt, b.position[1] + v[1] * dt, b.position[2] + v[2] * dt]
			out[int(b.id)] = _state(int(b.id), t, mode, newest.tick, p, b.rotation)
		return out
	var first: Dictionary = frames[0]
	if t <= first.t:
		for b in first.bodies:
			out[int(b.id)] = _state(int(b.id), t, "held", first.tick, b.position, b.rotation)
		return out
	var k := frames.size() - 1
	while k > 0 and frames[k - 1].t > t:
		k -= 1
	var fa: Dictionary = frames[k - 1]
	var fb: Dictionary = frames[k]
	var u: float = (t - fa.t) / (fb.t - fa.t)
	for sb in fb.bodies:
		var id := int(sb.id)
		var sa = fa.by_id.get(id)
		if sa == null:
			out[id] = _state(id, t, "held", fb.tick, sb.position, sb.rotation)
			continue
		var p: Array = []
		for i in 3:
			p.append(sa.position[i] + (sb.position[i] - sa.position[i]) * u)
		out[id] = _state(id, t, "interpolated", fa.tick, p, slerp(sa.rotation, sb.rotation, u))
	return out
