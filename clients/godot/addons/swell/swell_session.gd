extends Node
## A session on one scene's stream (GET /v1/scenes/{id}/stream, subprotocol swell.v1.json), by
## the JS client's rules (clients/js/src/session.js):
##
## - Requests carry an `id`; answers are matched by id (they may arrive out of order).
## - Clock sync: a ping every `ping_interval` s; each pong gives a sample (send time, receive
##   time, scene time) and the clock's rate, paused flag and generation (ClockSync in
##   clock_sync.gd). server_time() is scene time now, in seconds.
## - Clock changes (an admin seek, rate or pause change, or a scene put that moves the epoch): the
##   server sends a `clock` event and every later pong has the new generation. Either restarts the
##   fit (the old samples describe another clock): until the next pong server_time() follows the
##   event's reading at its rate, and `resync_pings` pings go out at once. A pong of an older
##   generation (sent before the change, answered after the restart) is dropped.
## - Tick subscription with an interest set (`bodies`, `region`); frames go to the `tick` signal
##   and to an optional BodyInterpolator (`interpolator`).
## - Reconnect: when the socket closes without close() having been called, it reopens after an
##   exponential backoff with jitter, re-sends the subscription and re-syncs the clock from
##   scratch; until the new connection's first pong server_time() answers from the old fit.
##
## Usage (in the tree): session.url = client.stream_url("calm"); if await session.open(): ...
## The socket is polled in _process, so the node must be processing.

const ClockSync := preload("clock_sync.gd")

## A tick frame {tick, t, bodies, impacts?}.
signal tick(frame: Dictionary)
## The scene's clock changed: {t, tick, tick_hz, rate, paused, unix, generation}.
signal clock_changed(event: Dictionary)
signal opened
## The socket closed; 4404 (SCENE_GONE): the scene was deleted, and no reconnect follows.
signal closed(code: int)
## An error the server sent that answers no request of this session ({code, message, field?}),
## e.g. not_found when the scene is deleted.
signal server_error(error: Dictionary)

## The Close code of a session whose scene was deleted.
const SCENE_GONE := 4404

## ws:// URL of the stream (SwellClient.stream_url).
@export var url: String = ""
## Seconds between pings.
@export var ping_interval: float = 1.0
## Pings open() sends one after another before it returns.
@export var sync_pings: int = 5
## Pings sent at a clock change.
@export var resync_pings: int = 3
## Seconds before a request without an answer fails.
@export var request_timeout: float = 10.0
## Reconnect backoff: first delay, most delay (s), factor.
@export var backoff_initial: float = 0.2
@export var backoff_max: float = 5.0
@export var backoff_factor: float = 2.0

## A BodyInterpolator (body_interpolator.gd) fed every tick frame, or null.
var interpolator = null
## The client clock in seconds (monotonic). Tests replace it.
var now: Callable = func() -> float: return Time.get_ticks_usec() / 1000000.0
var clock = _new_clock()
## The fit of the previous connection, answering server_time() until the new one has a sample.
var previous_clock = null
var last_tick = null
var last_pong = null
var last_clock = null
var reconnects: int = 0

var _ws: WebSocketPeer = null
var _state: int = WebSocketPeer.STATE_CLOSED
var _next_id: int = 1
var _pending: Dictionary = {}
var _subscription = null
var _closed: bool = true
var _attempt: int = 0
var _ping_due: float = 0.0
var _retry_at: float = -1.0
## The client time of the previous poll (see _process).
var _last_poll: float = -INF


## Seconds of samples before the fit estimates a drift (see ClockSync.min_drift_span).
const DRIFT_SPAN := 20.0


static func _new_clock(window: int = 32, best: int = 4, rate: float = 1.0, paused: bool = false, generation: int = -1):
	var c = ClockSync.new(window, best, rate, paused, generation)
	c.min_drift_span = DRIFT_SPAN
	return c


class _Waiter:
	extends RefCounted
	signal done(answer)
	var deadline: float
	var sent: float


## Opens the socket and returns once `sync_pings` pongs have arrived (false: it did not open).
func open() -> bool:
	_closed = false
	if not await _open():
		return false
	await sync_now(sync_pings)
	return clock.synced()


func _open() -> bool:
	_ws = WebSocketPeer.new()
	_ws.supported_protocols = PackedStringArray(["swell.v1.json"])
	var err := _ws.connect_to_url(url)
	if err != OK:
		_ws = null
		return false
	_state = WebSocketPeer.STATE_CONNECTING
	while _state == WebSocketPeer.STATE_CONNECTING:
		await get_tree().process_frame
	return _state == WebSocketPeer.STATE_OPEN


func _process(_delta: float) -> void:
	if _retry_at >= 0.0 and now.call() >= _retry_at:
		_retry_at = -1.0
		_reopen()
	if _ws == null:
		return
	# Messages are seen only when the socket is polled, once a frame: a pong that arrived just
	# after one poll waits a whole frame for the next (16–33 ms), and stamping it with this
	# poll's time would put the fit's midpoints half a frame late. A message seen now arrived
	# after the previous poll (which did not see it) and after its ping was sent: the later of
	# the two is the receive time. The error that leaves is half the true round trip when that
	# is under a frame (a LAN), and at most half a frame more beyond it.
	var seen_after := _last_poll
	_last_poll = now.call()
	_ws.poll()
	var st := _ws.get_ready_state()
	if st == WebSocketPeer.STATE_OPEN:
		if _state != WebSocketPeer.STATE_OPEN:
			_state = st
			_attempt = 0
			_ping_due = now.call() + ping_interval
			if _subscription != null:
				_send(_subscription)
			opened.emit()
		while _ws.get_available_packet_count() > 0:
			var pkt := _ws.get_packet()
			if _ws.was_string_packet():
				_on_message(pkt.get_string_from_utf8(), seen_after)
		var t: float = now.call()
		if t >= _ping_due:
			_ping_due = t + ping_interval
			ping()
		for id in _pending.keys():
			if t > _pending[id].deadline:
				var w: _Waiter = _pending[id]
				_pending.erase(id)
				w.done.emit({"type": "error", "code": "timeout", "message": "no answer within %s s" % request_timeout})
	elif st == WebSocketPeer.STATE_CLOSED:
		var code := _ws.get_close_code()
		_ws = null
		_state = st
		for id in _pending.keys():
			var w: _Waiter = _pending[id]
			w.done.emit({"type": "error", "code": "transport", "message": "socket closed (%d) before the answer" % code})
		_pending.clear()
		# The scene was deleted: reconnecting would be refused (404).
		if code == SCENE_GONE:
			_closed = true
		closed.emit(code)
		if not _closed:
			var base := minf(backoff_max, backoff_initial * pow(backoff_factor, _attempt))
			_attempt += 1
			_retry_at = now.call() + base * (0.5 + randf() * 0.5)


func _reopen() -> void:
	if _closed:
		return
	if await _open():
		reconnects += 1
		# A fresh estimate for the new connection (another server or path may have another
		# offset and round trip): the old fit answers until the new one has a sample.
		previous_clock = clock
		clock = _new_clock(clock.window, clock.best)
		await sync_now(sync_pings)
		previous_clock = null


func _send(msg: Dictionary) -> bool:
	if _ws == null or _ws.get_ready_state() != WebSocketPeer.STATE_OPEN:
		return false
	return _ws.send_text(JSON.stringify(msg, "", false, true)) == OK


## One request: the answer (its `type` and `id` kept), or {type: "error", code, message}.
func request(msg: Dictionary) -> Dictionary:
	var id := _next_id
	_next_id += 1
	var w := _Waiter.new()
	w.deadline = now.call() + request_timeout
	w.sent = msg.get("client_time", 0.0)
	msg["id"] = id
	_pending[id] = w
	if not _send(msg):
		_pending.erase(id)
		return {"type": "error", "code": "transport", "message": "the socket is not open"}
	return await w.done


## One ping: the pong ({client_time, scene_time, tick, rate, paused, generation}); feeds the clock.
func ping() -> Dictionary:
	return await request({"type": "ping", "client_time": now.call()})


## Sends `n` pings one after another (so their round trips do not inflate each other).
func sync_now(n: int = sync_pings):
	for i in n:
		var p := await ping()
		if p.get("type") == "error":
			break
	return clock


func _on_message(text: String, seen_after: float) -> void:
	# The earliest it can have arrived (see _process); _last_poll is this poll, the latest.
	var received: float = seen_after if seen_after > -INF else _last_poll
	var m = JSON.parse_string(text)
	if not m is Dictionary:
		return
	var type: String = m.get("type", "")
	if type == "tick":
		last_tick = m
		if interpolator != null:
			interpolator.push(m)
		tick.emit(m)
		return
	if type == "clock":
		_clock_changed(m, received)
		return
	if m.get("id") == null or not _pending.has(int(m.id)):
		if type == "error":
			server_error.emit(m)
		return
	var w: _Waiter = _pending[int(m.id)]
	_pending.erase(int(m.id))
	if type == "pong":
		var g: int = int(m.generation) if m.get("generation") != null else -1
		var cur: int = clock.generation
		if g >= 0 and cur >= 0 and g < cur:
			pass  # Answered before a change this session already restarted at: another clock's sample.
		else:
			if g != cur and (clock.synced() or cur < 0):
				_restart_fit(m, NAN)
			elif not clock.synced():
				# The first pong of a fit states the clock it samples.
				clock.rate = float(m.get("rate", 1.0))
				clock.paused = bool(m.get("paused", false))
				clock.generation = g
			# Ranked by the whole window it may have arrived in (send to this poll), placed at the
			# earliest moment in it.
			var sent := float(m.client_time)
			clock.add(sent, maxf(sent, _last_poll), float(m.scene_time), maxf(sent, received))
		last_pong = m
	w.done.emit(m)


# A new fit for the clock `c` (a pong or a `clock` event), with the event's reading as the
# estimate until the first pong (`received`: its arrival, or NAN for a pong).
func _restart_fit(c: Dictionary, received: float) -> void:
	var prev = clock
	var g: int = int(c.generation) if c.get("generation") != null else -1
	clock = _new_clock(prev.window, prev.best, float(c.get("rate", 1.0)), bool(c.get("paused", false)), g)
	if not is_nan(received):
		# The event left the server about one one-way delay before it arrived.
		var one_way: float = prev.min_rtt / 2.0 if not is_nan(prev.min_rtt) else 0.0
		clock.provisional = {"at": received - one_way, "t": float(c.t)}


func _clock_changed(m: Dictionary, received: float) -> void:
	_restart_fit(m, received)
	last_clock = m
	clock_changed.emit(m)
	if _state == WebSocketPeer.STATE_OPEN:
		sync_now(resync_pings)


## Whether server_time() can answer.
func synced() -> bool:
	return clock.synced() or (previous_clock != null and previous_clock.synced())


## Scene time now (s) from the synced clock (NAN before the first pong).
func server_time() -> float:
	var c = clock if clock.synced() else previous_clock
	if c == null or not c.synced():
		return NAN
	return c.scene_time(now.call())


## Subscribes to tick frames: `bodies` (ids) and/or `region` ([x0, z0, x1, z1]) pick the bodies
## a frame carries (neither: all). Kept and re-sent after a reconnect.
func subscribe(bodies = null, region = null) -> void:
	var sub := {"type": "subscribe", "ticks": true}
	if bodies != null:
		sub["bodies"] = bodies
	if region != null:
		sub["region"] = region
	_subscription = sub
	_send(sub)


## Stops tick frames.
func unsubscribe() -> void:
	_subscription = null
	_send({"type": "subscribe", "ticks": false})


## A sample query on the socket: the same answer as POST …/sample.
func sample(req: Dictionary) -> Dictionary:
	var m := req.duplicate()
	m["type"] = "sample"
	return await request(m)


## Closes the socket for good (no reconnect).
func close() -> void:
	_closed = true
	_retry_at = -1.0
	if _ws != null:
		_ws.close(1000)


func _exit_tree() -> void:
	close()
