extends RefCounted
## Clock synchronisation from ping/pong samples: the JS client's ClockSync
## (clients/js/src/session.js), rule for rule. Times are seconds: client time on a local
## monotonic clock, scene time on the scene clock.
##
## One fit describes one clock generation (the server counts every seek, rate or pause change and
## every put that moves the epoch; pongs and `clock` events carry it): the session starts a new fit
## at each new generation, so samples from before a change never mix with those after it. The scene
## clock runs at the rate the server states (slope = rate, or 0 while paused), so each sample gives
## the offset of scene_time − slope·mid, and the fitted drift is only the two machines'
## clock-frequency error.

## Samples kept (the newest).
var window: int = 32
## Lowest-RTT samples the offset is averaged from.
var best: int = 4
var samples: Array = []
var offset: float = NAN
var drift: float = 0.0
var ref: float = 0.0
var rtt: float = NAN
var min_rtt: float = NAN
var rate: float = 1.0
var paused: bool = false
## The server's clock generation this fit describes (-1: a server that sends none).
var generation: int = -1
## The shortest span of samples (s) a drift is fitted over. The JS client's 1 s suits samples
## stamped as they arrive (sub-millisecond noise); SwellSession raises it, since its samples are
## stamped at frame polls (milliseconds of noise, which over 1 s would fit a drift of 1 %).
var min_drift_span: float = 1.0
## Before the first sample of a generation announced by a `clock` event: the event's reading
## {"at": client time of its arrival less the previous one-way delay, "t": scene time}.
var provisional = null


func _init(p_window: int = 32, p_best: int = 4, p_rate: float = 1.0, p_paused: bool = false, p_generation: int = -1) -> void:
	window = p_window
	best = p_best
	rate = p_rate
	paused = p_paused
	generation = p_generation


## Scene seconds per client second: the rate, or 0 while paused.
func slope() -> float:
	return 0.0 if paused else rate


## Whether there is at least one sample (or a `clock` event's reading).
func synced() -> bool:
	return samples.size() > 0 or provisional != null


## Adds a sample: ping sent at `sent`, pong received at `received` (client clock), the pong's
## scene time. `at`: the client time the scene time is taken to belong to, when the caller
## knows better than the midpoint (SwellSession: the earliest the pong can have arrived);
## `received − sent` still ranks the samples.
func add(sent: float, received: float, scene_time: float, at: float = NAN) -> void:
	var r := received - sent
	var mid := sent + r / 2.0 if is_nan(at) else at
	samples.append({"rtt": r, "mid": mid, "offset": scene_time - slope() * mid})
	if samples.size() > window:
		samples.pop_front()
	rtt = r
	var sorted := samples.duplicate()
	# A stable sort, as JS's Array.prototype.sort is: equal RTTs keep their arrival order.
	for i in range(sorted.size()):
		sorted[i] = [sorted[i], i]
	sorted.sort_custom(func(a, b): return a[0].rtt < b[0].rtt or (a[0].rtt == b[0].rtt and a[1] < b[1]))
	for i in range(sorted.size()):
		sorted[i] = sorted[i][0]
	# The lowest-RTT samples, leaving out any over twice the best round trip (+ 1 ms): a round
	# trip held up on one side carries up to all of its extra delay into its offset, and just
	# after a clock change, with a handful of samples, one such would be averaged in.
	var good: Array = [sorted[0]]
	for s in sorted.slice(1, mini(best, sorted.size())):
		if s.rtt <= 2.0 * sorted[0].rtt + 1e-3:
			good.append(s)
	# Drift: slope of offset against time over the samples within twice the best RTT (needs a
	# spread of at least a second to mean anything; none while paused: the clock stands still).
	var within: Array = []
	for s in samples:
		if s.rtt <= 2.0 * sorted[0].rtt + 1e-3:
			within.append(s)
	var m0 := 0.0
	var o0 := 0.0
	for s in within:
		m0 += s.mid
	m0 /= within.size()
	for s in within:
		o0 += s.offset
	o0 /= within.size()
	var sxx := 0.0
	var sxy := 0.0
	for s in within:
		sxx += (s.mid - m0) * (s.mid - m0)
		sxy += (s.mid - m0) * (s.offset - o0)
	var span: float = within[within.size() - 1].mid - within[0].mid if within.size() > 1 else 0.0
	drift = sxy / sxx if slope() != 0.0 and span >= min_drift_span and sxx > 0.0 else 0.0
	# Offset at `ref` from the lowest-RTT samples, each carried to ref along the drift.
	ref = 0.0
	for s in good:
		ref += s.mid
	ref /= good.size()
	offset = 0.0
	for s in good:
		offset = offset + s.offset + drift * (ref - s.mid)  # (a + offset) + drift term, as JS sums
	offset /= good.size()
	min_rtt = sorted[0].rtt


## Scene time at client time `c` (s).
func scene_time(c: float) -> float:
	if samples.is_empty() and provisional != null:
		return provisional.t + slope() * (c - provisional.at)
	return slope() * c + offset + drift * (c - ref)
