extends Node
## The addon's tests, run by .ci/godot-check in Godot 4.6's web build (headless Chromium):
## the harness (.ci/godot-gdscript.mjs) packs addons/swell and this folder into a .pck with
## this script's scene as the main scene, passes the server's address after `--`, and reads
## what this prints. Lines: "PASS name", "FAIL name: why", and last "SWELL-GODOT-TESTS
## passed=N failed=M".
##
## Fixed-input tests compare with expected.json, which the harness writes from the JS client
## (clients/js/src) run on the same inputs: the values must be the same bits (hex of the f64).
## Live tests talk to a real `swell` (the harness starts it on 127.0.0.1).

const SwellMath := preload("res://addons/swell/swell_math.gd")
const ClockSync := preload("res://addons/swell/clock_sync.gd")
const BodyInterpolator := preload("res://addons/swell/body_interpolator.gd")
const SwellSurface := preload("res://addons/swell/swell_surface.gd")
const SwellClient := preload("res://addons/swell/swell_client.gd")
const SwellSession := preload("res://addons/swell/swell_session.gd")
const SwellOcean := preload("res://addons/swell/swell_ocean.gd")
const SwellJson := preload("res://addons/swell/swell_json.gd")

var passed := 0
var failed := 0
var http_base := ""
var ws_base := ""
var admin_token := ""
var expected: Dictionary = {}


func _ready() -> void:
	for a in OS.get_cmdline_user_args():
		if a.begins_with("--http="):
			http_base = a.substr(7)
		elif a.begins_with("--ws="):
			ws_base = a.substr(5)
		elif a.begins_with("--admin="):
			admin_token = a.substr(8)
	expected = JSON.parse_string(FileAccess.get_file_as_string("res://tests/expected.json"))
	print("swell godot tests: ", Engine.get_version_info().string, " http=", http_base, " ws=", ws_base)
	test_phase_reduction()
	test_clock_sync_fixed()
	test_interpolator_fixed()
	test_json_decimals()
	if http_base != "":
		await test_http()
		await test_uniforms_match_server()
		await test_session_clock_sync()
		await test_clock_changes()
		await test_join_paused_and_rate2()
		await test_ticks_and_interpolation()
		await test_ocean_node()
		await test_reconnect()
	print("SWELL-GODOT-TESTS passed=%d failed=%d" % [passed, failed])


func check(ok: bool, name: String, why: String = "") -> void:
	if ok:
		passed += 1
		print("PASS ", name)
	else:
		failed += 1
		print("FAIL ", name, ": ", why)


static func hex(x: float) -> String:
	# Big-endian hex of the f64's bits, as proto/vectors and the harness write them.
	var b := PackedFloat64Array([x]).to_byte_array()
	b.reverse()
	return b.hex_encode()


static func wall() -> float:
	return Time.get_unix_time_from_system()


func wait(s: float) -> void:
	await get_tree().create_timer(s).timeout


# --- fixed inputs, expected outputs -------------------------------------------------------

func test_phase_reduction() -> void:
	var xs := [0.0, 1.0, -1.0, 3.5, 1e6, -2.7e10 + 0.25, 123456.789, 7.0 * PI]
	var got: Array = []
	for x in xs:
		got.append(hex(SwellMath.reduce_phase(x)))
	check(got == expected.reduce_phase, "reduce_phase: the model's bits", "%s != %s" % [got, expected.reduce_phase])
	check(SwellMath.round_ties_away(2.5) == 3.0 and SwellMath.round_ties_away(-2.5) == -3.0, "round_ties_away: ties away from zero")


# The JS client's ClockSync tests (clients/js/test/interp.test.js, session.test.js), and their
# outputs from the JS code itself, bit for bit.
func test_clock_sync_fixed() -> void:
	var c := ClockSync.new(32, 2)
	c.add(0.0, 0.002, 1000.001)
	c.add(1.0, 1.200, 1001.190)  # 200 ms RTT, answer late: its midpoint is off by 90 ms
	c.add(2.0, 2.002, 1002.001)
	check(absf(c.offset - 1000.0) < 1e-9, "clock: offset from the lowest round trips", str(c.offset))
	check(hex(c.scene_time(10.0)) == expected.clock_best.scene_time_10, "clock: lowest-RTT fit equals the JS client's bits", "%s vs %s" % [hex(c.scene_time(10.0)), expected.clock_best.scene_time_10])
	# Drift: scene = 1000 + (1 + 2e-4)·client, one-way delays 1–6 ms from the tests' LCG.
	var drift := 2e-4
	var d := ClockSync.new(64, 4)
	# The LCG's state in an Array (a lambda captures locals by value), in doubles as the JS
	# test computes it (x·1103515245 exceeds 2⁵³ there and rounds).
	var lcg := [7.0]
	var noise := func() -> float:
		lcg[0] = fmod(lcg[0] * 1103515245.0 + 12345.0, 2147483648.0)
		return lcg[0] / 2147483648.0
	for i in 60:
		var sent := i * 0.1
		var up: float = 0.001 + 0.005 * noise.call()
		var down: float = 0.001 + 0.005 * noise.call()
		d.add(sent, sent + up + down, 1000.0 + (1.0 + drift) * (sent + up))
	check(absf(d.drift - drift) < 2e-5, "clock: drift tracked", str(d.drift))
	var got := [hex(d.drift), hex(d.offset), hex(d.scene_time(30.0))]
	var want: Array = [expected.clock_drift.drift, expected.clock_drift.offset, expected.clock_drift.scene_time_30]
	check(got == want, "clock: drift fit equals the JS client's bits", "%s vs %s" % [got, want])
	# Just after a change to rate 2: three samples, the third held up 30 ms on its way back; it
	# is left out of the offset (the JS client's test of the same name).
	var h := ClockSync.new(32, 4, 2.0, false, 1)
	h.add(10.0, 10.0002, 1000.0 + 2.0 * 10.0001)
	h.add(10.1, 10.1002, 1000.0 + 2.0 * 10.1001)
	h.add(10.2, 10.2302, 1000.0 + 2.0 * 10.2001)
	check(absf(h.scene_time(11.0) - 1022.0) < 1e-9, "clock: a held-up round trip left out of the offset", str(h.scene_time(11.0) - 1022.0))
	# A clock event's reading answers until the first pong; a paused clock stands still.
	var p := ClockSync.new(32, 4, 2.0, false, 5)
	p.provisional = {"at": 10.0, "t": 500.0}
	check(p.synced() and p.scene_time(10.5) == 501.0, "clock: provisional reading at the event's rate")
	var q := ClockSync.new(32, 4, 1.0, true, 6)
	q.add(0.0, 0.002, 777.25)
	q.add(3.0, 3.002, 777.25)
	check(q.scene_time(100.0) == 777.25 and q.drift == 0.0, "clock: paused fit stands still", str(q.scene_time(100.0)))


static func body(id: int, x: float, vx: float = 0.0) -> Dictionary:
	return {"id": id, "position": [x, 0.0, 0.0], "rotation": [0.0, 0.0, 0.0, 1.0], "velocity": [vx, 0.0, 0.0]}


func test_interpolator_fixed() -> void:
	var ip := BodyInterpolator.new(0.1, 3, 0.2)
	ip.push({"tick": 30, "t": 1.0, "bodies": [body(1, 0.0)]})
	ip.push({"tick": 31, "t": 1.1, "bodies": [body(1, 1.0, 10.0)]})
	var s: Dictionary = ip.sample(1.05)[1]
	check(s.mode == "interpolated" and absf(s.position_f64[0] - 0.5) < 1e-12, "interp: between the frames around t", str(s))
	var got := [hex(s.position_f64[0])]
	s = ip.sample(1.2)[1]
	check(s.mode == "extrapolated" and absf(s.position_f64[0] - 2.0) < 1e-9, "interp: extrapolated along the velocity", str(s))
	got.append(hex(s.position_f64[0]))
	s = ip.sample(5.0)[1]
	check(s.mode == "held" and absf(s.position_f64[0] - 3.0) < 1e-9, "interp: extrapolation stops at max_extrapolation", str(s))
	got.append(hex(s.position_f64[0]))
	check(ip.at(1.15)[1].mode == "interpolated", "interp: at() renders delay behind")
	ip.push({"tick": 32, "t": 1.2, "bodies": [body(1, 2.0)]})
	ip.push({"tick": 33, "t": 1.3, "bodies": [body(1, 3.0)]})
	check(ip.frames.size() == 3 and ip.frame_at(30) == null, "interp: bounded, the oldest frame goes")
	ip.push({"tick": 10, "t": 0.33, "bodies": [body(1, 9.0)]})
	check(ip.frames.size() == 1, "interp: a clock that ran backwards resets the buffer")
	# Rotation: slerp between two yaws, against the JS client's bits.
	var r := BodyInterpolator.new(0.0)
	var h := 0.5 * 1.2
	r.push({"tick": 1, "t": 0.0, "bodies": [{"id": 7, "position": [0.0, 0.0, 0.0], "rotation": [0.0, 0.0, 0.0, 1.0]}]})
	r.push({"tick": 2, "t": 1.0, "bodies": [{"id": 7, "position": [4.0, 1.0, -2.0], "rotation": [0.0, sin(h), 0.0, cos(h)]}]})
	var m: Dictionary = r.sample(0.3)[7]
	for v in m.position_f64:
		got.append(hex(v))
	for v in m.rotation_f64:
		got.append(hex(v))
	check(got == expected.interp, "interp: positions and rotations equal the JS client's bits", "%s vs %s" % [got, expected.interp])


# How many of the scene's decimals (the JS client's JSON.parse, correctly rounded, gave the
# bits) Godot's JSON.parse_string reads to other bits. A report, not a check: it is why the
# uniforms test compares phases within 4e-15·max(1, t) rad and not bit for bit.
func test_json_decimals() -> void:
	var godot_off := 0
	var bad: Array = []
	for pair in expected.decimals:
		if hex(float(JSON.parse_string(pair[0]))) != pair[1]:
			godot_off += 1
		if hex(SwellJson.to_double(pair[0])) != pair[1]:
			bad.append("%s: %s, JS %s" % [pair[0], hex(SwellJson.to_double(pair[0])), pair[1]])
	print("  json: %d of %d decimals parse to other bits in Godot's JSON than in JS; SwellJson: %d" % [godot_off, expected.decimals.size(), bad.size()])
	check(expected.decimals.size() > 40 and bad.is_empty(), "json: SwellJson reads %d decimals (GET /v1/scenes/{calm,lake} and hard cases) to JS's bits" % expected.decimals.size(), str(bad.slice(0, 5)))
	# Numbers inside strings are not numbers; every number of the text is read again, in order.
	var text := '{"a":"x -1.5 \\" 2e3","b":[0.1,-2.5e-3,{"c":1.7976931348623157e308,"d":[]}],"e":true,"f":null,"g":3,"h":5e-324}'
	var v = SwellJson.parse(text)
	var ok: bool = v is Dictionary and v.a == 'x -1.5 " 2e3' and v.b.size() == 3 and hex(v.b[0]) == "3fb999999999999a" \
		and hex(v.b[1]) == "bf647ae147ae147b" and hex(v.b[2].c) == "7fefffffffffffff" and v.e == true and v.f == null \
		and float(v.g) == 3.0 and hex(v.h) == "0000000000000001"
	check(ok, "json: SwellJson.parse reads a document's numbers and leaves its strings", str(v))
	check(SwellJson.parse("{not json") == null, "json: SwellJson.parse of a broken text is null")


# --- against a real server ----------------------------------------------------------------

func new_client() -> Node:
	var c = SwellClient.new()
	c.base_url = http_base
	c.admin_token = admin_token
	add_child(c)
	return c


func new_session(scene: String) -> Node:
	var s = SwellSession.new()
	s.url = ws_base + "/v1/scenes/" + scene + "/stream"
	add_child(s)
	return s


func test_http() -> void:
	var c = new_client()
	var list = await c.scenes()
	var ids: Array = []
	if list != null:
		for s in list.scenes:
			ids.append(s.id)
	check(ids.has("calm") and ids.has("harbour"), "http: GET /v1/scenes lists the built-in scenes", str(ids))
	var sc = await c.scene("calm")
	check(sc != null and sc.derived.layers[0].kind == "sine", "http: GET /v1/scenes/calm", str(c.last_error))
	var h = await c.height("calm", 3.5, -2.0, 12.25)
	var smp = await c.sample("calm", {"t": 12.25, "points": [[3.5, -2.0]], "fields": ["height"]})
	check(h != null and smp != null and hex(h.height) == hex(smp.height[0]), "http: height and sample agree bit for bit", "%s %s" % [h, smp])
	var missing = await c.scene("no-such-scene")
	check(missing == null and c.last_error.status == 404, "http: an unknown scene is a 404 in last_error", str(c.last_error))
	var inc = await c.shader_include("calm")
	check(inc != null and inc.contains("swell_u_phases"), "http: the scene's .gdshaderinc")
	c.queue_free()


func test_uniforms_match_server() -> void:
	var c = new_client()
	var bad: Array = []
	var n := 0
	for id in ["calm", "lake", "open-sea"]:
		var surf := SwellSurface.new(await c.scene(id))
		for tc in [[0.0, 0.0, 0.0], [10.0, 5.0, 7.0], [28417808.757, -1000.5, 333.25], [1e6 + 0.1, 1e6, -1e6]]:
			var u = await c.uniforms(id, tc[0], Vector2.ZERO, [tc[1], tc[2]])
			var mine := surf.uniforms(tc[0], tc[1], tc[2])
			for i in u.phases.size():
				n += 1
				# The server's bits: both answers' numbers are read exactly (SwellJson).
				if hex(mine.phases[i]) != hex(u.phases[i]):
					bad.append("%s t=%s phase %d: %s vs server %s" % [id, tc[0], i, hex(mine.phases[i]), hex(u.phases[i])])
			for i in u.block.size():
				n += 1
				if mine.block[i] != PackedFloat32Array([float(u.block[i])])[0]:
					bad.append("%s t=%s block[%d]: %s vs %s" % [id, tc[0], i, mine.block[i], u.block[i]])
	check(bad.is_empty() and n > 100, "uniforms: %d values equal GET …/uniforms bit for bit (f64 phases, f32 block) on calm, lake, open-sea" % n, str(bad.slice(0, 5)))
	c.queue_free()


func test_session_clock_sync() -> void:
	var c = new_client()
	var s = new_session("calm")
	s.ping_interval = 0.1
	s.sync_pings = 10
	check(await s.open(), "session: opens and syncs")
	await wait(0.3)
	var r = await c.clock("calm")
	var truth: float = r.t + r.rate * (wall() - r.unix)
	var err: float = s.server_time() - truth
	print("  clock sync: error %.3f ms, min RTT %.3f ms" % [err * 1e3, s.clock.min_rtt * 1e3])
	check(absf(err) < bound(r), "session: server_time() within 15 ms of the scene clock", "%s s" % err)
	var ans = await s.sample({"t": 12.25, "points": [[3.5, -2.0]], "fields": ["height"]})
	var smp = await c.sample("calm", {"t": 12.25, "points": [[3.5, -2.0]], "fields": ["height"]})
	check(ans.get("type") == "sample_result" and hex(ans.height[0]) == hex(smp.height[0]), "session: sample on the socket equals HTTP", str(ans))
	s.close()
	s.queue_free()
	c.queue_free()


const SMALL_SPEC := {"description": "godot clock test", "tick_hz": 20, "seed": 3, "layers": [{"kind": "gerstner", "waves": [{"amplitude": 0.4, "wavelength": 30, "direction": [1, 0.5], "steepness": 0.6}]}]}


# The bound for a Godot session: a message is seen when the socket is polled, once a frame, so a
# pong's arrival is known only to within a frame (swell_session.gd stamps it at the previous
# poll), and what is left is about the one-way delay, times the rate. Measured here (Godot web,
# headless Chromium, SwiftShader, a debug swell, 2 vCPUs): 1–6 ms at rate 1 and 0–12 ms at rate 2
# 1 s after a change; joining a rate-2 scene, one pong: 0–27 ms, the most with compilers
# running beside it (load average 17). The JS client, which stamps each message as it arrives,
# holds 5 ms.
static func bound(r: Dictionary) -> float:
	return 0.015 * maxf(1.0, absf(float(r.rate)))


static func truth_of(r: Dictionary) -> float:
	return r.t + (0.0 if r.paused else r.rate) * (wall() - r.unix)


# Issue 28's clock test: seek and rate changes while connected, server_time() within 5 ms of
# the truth 1 s after each.
func test_clock_changes() -> void:
	var c = new_client()
	var put = await c.put_scene("godot-clock", SMALL_SPEC)
	check(put != null, "clock change: PUT a scene (admin)", str(c.last_error))
	var s = new_session("godot-clock")
	var events: Array = []
	s.clock_changed.connect(func(e): events.append(e))
	await s.open()
	for step in [["seek", {"t": 118000}], ["rate 1 -> 2", {"rate": 2}], ["pause", {"paused": true}], ["resume", {"paused": false}], ["seek back, rate -1", {"t": 50, "rate": -1}]]:
		var before: int = s.clock.generation
		var r = await c.set_clock("godot-clock", step[1])
		await wait(1.0)
		var err: float = s.server_time() - truth_of(r)
		print("  clock change (%s): error 1 s after %.3f ms, generation %d" % [step[0], err * 1e3, s.clock.generation])
		var ok: bool = r != null and int(r.generation) == before + 1 and absf(err) < bound(r) and s.clock.generation == int(r.generation) and events.size() > 0 and int(events[-1].generation) == int(r.generation)
		check(ok, "clock change (%s): server_time() within 15 ms·max(1, |rate|) 1 s after, new generation, a clock event" % step[0], "err %s s, generation %s, events %d" % [err, s.clock.generation, events.size()])
	s.close()
	s.queue_free()
	c.queue_free()


func test_join_paused_and_rate2() -> void:
	var c = new_client()
	for step in [["paused", {"t": 777.25, "paused": true}], ["rate 2", {"paused": false, "rate": 2}]]:
		await c.put_scene("godot-join", SMALL_SPEC)
		var r = await c.set_clock("godot-join", step[1])
		var s = new_session("godot-join")
		s.sync_pings = 1
		await s.open()
		var err: float = s.server_time() - truth_of(r)
		print("  joining a %s scene: error after the first pong %.3f ms" % [step[0], err * 1e3])
		check(absf(err) < bound(r) and s.clock.samples.size() == 1, "joining a %s scene: server_time() within 15 ms·max(1, |rate|) after the first pong" % step[0], "%s s" % err)
		s.close()
		s.queue_free()
	c.queue_free()


func test_ticks_and_interpolation() -> void:
	var c = new_client()
	var a = await c.spawn_body("calm", {"mass": 3000, "hull": {"kind": "box", "length": 8, "beam": 3, "height": 1.5}, "position": [0, 0.5, 0]})
	var b = await c.spawn_body("calm", {"mass": 500, "hull": {"kind": "box", "length": 3, "beam": 1.5, "height": 1}, "position": [100, 0.5, 100]})
	check(a != null and b != null, "bodies: spawned two boats on calm", str(c.last_error))
	if a == null or b == null:
		return
	var s = new_session("calm")
	var ip := BodyInterpolator.new(0.1)
	s.interpolator = ip
	var frames: Array = []
	s.tick.connect(func(f): frames.append(f))
	await s.open()
	s.subscribe([int(a.id)])
	await wait(1.0)
	var only_a := frames.size() > 10
	for f in frames:
		for bb in f.bodies:
			if int(bb.id) != int(a.id):
				only_a = false
	check(only_a, "ticks: subscribe by id gets frames with that body only", "%d frames" % frames.size())
	var n: int = ip.frames.size()
	var ok := n >= 2
	var why := "%d frames" % n
	if ok:
		var fa: Dictionary = ip.frames[n - 2]
		var fb: Dictionary = ip.frames[n - 1]
		print("  ticks: the newest frame is %.1f ms behind server_time()" % ((s.server_time() - fb.t) * 1e3))
		var st: Dictionary = ip.sample(0.25 * fa.t + 0.75 * fb.t)[int(a.id)]
		var pa: Array = fa.by_id[int(a.id)].position
		var pb: Array = fb.by_id[int(a.id)].position
		for i in 3:
			var want: float = pa[i] + (pb[i] - pa[i]) * ((st.t - fa.t) / (fb.t - fa.t))
			ok = ok and absf(st.position_f64[i] - want) < 1e-12
		ok = ok and st.mode == "interpolated"
		why = str(st)
	check(ok, "ticks: the interpolator puts the body between the two frames around t, on real tick frames", why)
	s.close()
	s.queue_free()
	c.queue_free()


func test_ocean_node() -> void:
	for id in ["calm", "harbour"]:
		var ocean = SwellOcean.new()
		ocean.server_url = http_base
		ocean.scene_id = id
		ocean.size = 64.0
		ocean.subdivisions = 32
		ocean.position = Vector3(1000.0, 0.0, -250.0)
		add_child(ocean)
		# The session's socket goes to the stream's own address (the page's origin is the harness).
		ocean.session.url = ws_base + "/v1/scenes/" + id + "/stream"
		await ocean.ready_to_draw
		await wait(0.5)
		var ok: bool = ocean.material != null and ocean.material.shader.code.contains("swell_sample") and not is_nan(ocean.last_time) and ocean.last_block.size() > 0
		var phases = ocean.material.get_shader_parameter("swell_u_phases")
		var want: float = ocean.last_block[0] if ocean.last_block.size() > 0 else NAN
		ok = ok and phases != null and phases.size() > 0 and phases[0].x == want
		var names: Array = ocean.uniform_layout.map(func(u): return "%s[%d]" % [u[0], u[1]])
		var layout := ", ".join(PackedStringArray(names))
		check(ok, "ocean (%s): the include's material draws, its uniforms set every frame (%s)" % [id, layout], "last_time %s, block %d" % [ocean.last_time, ocean.last_block.size()])
		ocean.queue_free()


# The server drops the socket (here a message over the harness's 16 KiB ws_max_message_bytes:
# Close 1009): the session reconnects after its backoff, re-sends its subscription (tick frames
# come again) and answers requests on the new socket, its clock fit restarted and in sync.
func test_reconnect() -> void:
	var c = new_client()
	var s = new_session("calm")
	s.ping_interval = 0.2
	var codes: Array = []
	s.closed.connect(func(code): codes.append(code))
	var frames: Array = []
	s.tick.connect(func(f): frames.append(f))
	await s.open()
	s.subscribe()
	await wait(0.5)
	var before := frames.size()
	s._ws.send_text("x".repeat(20000))
	var deadline := wall() + 10.0
	while s.reconnects < 1 and wall() < deadline:
		await wait(0.05)
	frames.clear()
	await wait(1.0)
	var pong = await s.ping()
	var r = await c.clock("calm")
	var err: float = s.server_time() - truth_of(r)
	print("  reconnect: closed with %s, %d reconnect(s), %d frames before, %d in the second after; clock error %.3f ms" % [str(codes), s.reconnects, before, frames.size(), err * 1e3])
	var ok: bool = codes.size() == 1 and s.reconnects == 1 and before > 5 and frames.size() > 5 and pong.get("type") == "pong" and absf(err) < bound(r)
	check(ok, "reconnect: a dropped session reconnects, re-subscribes and answers, its clock in sync", "closes %s, reconnects %d, frames %d then %d, pong %s, err %s s" % [str(codes), s.reconnects, before, frames.size(), str(pong), err])
	s.close()
	s.queue_free()
	c.queue_free()
