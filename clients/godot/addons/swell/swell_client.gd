extends Node
## HTTP client of a Swell server (the endpoints of docs/api.md), one HTTPRequest per call.
## Every call is a coroutine: `var scene = await client.scene("calm")`. A call that fails
## returns null and leaves {status, code, message, field} in `last_error` (status 0: no answer).
##
## Add it to the tree first (HTTPRequest nodes are its children). Numbers go out with
## JSON.stringify(..., full_precision = true): times and positions keep all 17 digits.

const SwellJson := preload("swell_json.gd")

## Base URL, e.g. "http://127.0.0.1:8080" (no trailing slash needed).
@export var base_url: String = "http://127.0.0.1:8080"
## Admin bearer token, only for set_clock.
@export var admin_token: String = ""
## Per-request timeout, s.
@export var timeout: float = 10.0

var last_error = null


## The WebSocket URL of a scene's stream.
func stream_url(scene_id: String) -> String:
	var b := base_url.trim_suffix("/")
	return ("ws" + b.substr(4)) + "/v1/scenes/" + scene_id.uri_encode() + "/stream"


## GET /v1/scenes: {scenes: [{id, description, layers, tick_hz}]}.
func scenes():
	return await request_json(HTTPClient.METHOD_GET, "/v1/scenes")


## GET /v1/scenes/{id}: spec, derived (every built wave), model_version, spec_hash, clock.
## Its numbers are read exactly (SwellJson), so SwellSurface computes the server's bits.
func scene(id: String):
	return await request_json(HTTPClient.METHOD_GET, "/v1/scenes/" + id.uri_encode(), null, false, "", true)


## GET /v1/scenes/{id}/clock: {t, tick, tick_hz, rate, paused, unix, generation}.
func clock(id: String):
	return await request_json(HTTPClient.METHOD_GET, "/v1/scenes/" + id.uri_encode() + "/clock")


## PUT /v1/scenes/{id}/clock (admin): seek (`t`), `rate` and/or `paused` (keys of `change`).
func set_clock(id: String, change: Dictionary):
	return await request_json(HTTPClient.METHOD_PUT, "/v1/scenes/" + id.uri_encode() + "/clock", change, true)


## GET …/height?x=&z=[&t=]: {t, height} at world (x, z); t < 0 or NAN: the scene's now.
func height(id: String, x: float, z: float, t: float = NAN):
	var q := "?x=%s&z=%s" % [_num(x), _num(z)]
	if not is_nan(t):
		q += "&t=" + _num(t)
	return await request_json(HTTPClient.METHOD_GET, "/v1/scenes/" + id.uri_encode() + "/height" + q)


## POST …/sample: `req` = {t?, origin?, points: [[x, z], ...], fields?} → {t, height: [...], ...}.
func sample(id: String, req: Dictionary):
	return await request_json(HTTPClient.METHOD_POST, "/v1/scenes/" + id.uri_encode() + "/sample", req)


## POST …/orientation: {bodies: [{position: [x, z], yaw, length, beam}]} → {t, bodies: [...]}.
func orientation(id: String, req: Dictionary):
	return await request_json(HTTPClient.METHOD_POST, "/v1/scenes/" + id.uri_encode() + "/orientation", req)


## GET …/uniforms?t=&origin=x,z: the frame's uniform block as the server computes it.
func uniforms(id: String, t: float = NAN, origin: Vector2 = Vector2.ZERO, origin_f64: Array = []):
	var o: Array = origin_f64 if origin_f64.size() == 2 else [origin.x, origin.y]
	var q := "?origin=%s,%s" % [_num(o[0]), _num(o[1])]
	if not is_nan(t):
		q += "&t=" + _num(t)
	return await request_json(HTTPClient.METHOD_GET, "/v1/scenes/" + id.uri_encode() + "/uniforms" + q, null, false, "", true)


## GET …/shader?lang=gdshaderinc: the scene's Godot shader include, as text (null on failure).
func shader_include(id: String):
	var r = await request(HTTPClient.METHOD_GET, "/v1/scenes/" + id.uri_encode() + "/shader?lang=gdshaderinc")
	return null if r == null else r.get_string_from_utf8()


## POST …/bodies (game role; an admin token also works): spawn a body; its state {id, ...}.
func spawn_body(id: String, spec: Dictionary, token: String = ""):
	return await request_json(HTTPClient.METHOD_POST, "/v1/scenes/" + id.uri_encode() + "/bodies", spec, token == "", token)


## PUT /v1/scenes/{id} (admin): create or replace a scene from its spec.
func put_scene(id: String, spec: Dictionary):
	return await request_json(HTTPClient.METHOD_PUT, "/v1/scenes/" + id.uri_encode(), spec, true)


## A number as the query string takes it, all 17 significant digits.
static func _num(x: float) -> String:
	return JSON.stringify(x, "", false, true)


## One JSON request: the parsed answer, or null (see last_error). `exact`: every number read to
## the nearest double (SwellJson; Godot's own parser reads some an ulp off), for answers whose
## numbers must be the server's bits.
func request_json(method: int, path: String, body = null, admin: bool = false, token: String = "", exact: bool = false):
	var raw = await request(method, path, body, admin, token)
	if raw == null:
		return null
	var text: String = raw.get_string_from_utf8()
	var parsed = SwellJson.parse(text) if exact else JSON.parse_string(text)
	if parsed == null:
		last_error = {"status": 200, "code": "bad_json", "message": "the answer to %s is not JSON" % path}
	return parsed


## One request: the body's bytes on a 2xx, else null (see last_error).
func request(method: int, path: String, body = null, admin: bool = false, token: String = ""):
	var headers := PackedStringArray(["accept: application/json"])
	var data := ""
	if body != null:
		data = JSON.stringify(body, "", false, true)
		headers.append("content-type: application/json")
	if admin:
		token = admin_token
	if token != "":
		headers.append("authorization: Bearer " + token)
	var req := HTTPRequest.new()
	req.timeout = timeout
	add_child(req)
	var err := req.request(base_url.trim_suffix("/") + path, headers, method, data)
	if err != OK:
		req.queue_free()
		last_error = {"status": 0, "code": "transport", "message": "cannot send %s: error %d" % [path, err]}
		return null
	var res: Array = await req.request_completed
	req.queue_free()
	var result: int = res[0]
	var status: int = res[1]
	var bytes: PackedByteArray = res[3]
	if result != HTTPRequest.RESULT_SUCCESS:
		last_error = {"status": 0, "code": "transport", "message": "%s: HTTPRequest result %d" % [path, result]}
		return null
	if status < 200 or status >= 300:
		var e = JSON.parse_string(bytes.get_string_from_utf8())
		last_error = {"status": status, "code": "http_%d" % status, "message": bytes.get_string_from_utf8()}
		if e is Dictionary and e.get("error") is Dictionary:
			last_error.merge(e.error, true)
		return null
	last_error = null
	return bytes
