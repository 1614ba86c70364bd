#!/usr/bin/env python3
"""Writes the fuzz targets' seed inputs (fuzz/seeds/<target>/): a few valid requests of each kind,
so libFuzzer starts from inputs that reach the queries instead of rediscovering JSON and protobuf
framing. Re-run after changing a request type: python3 fuzz/seeds/make_seeds.py"""
import json, os, struct

HERE = os.path.dirname(os.path.abspath(__file__))

def write(target, name, data):
    d = os.path.join(HERE, target)
    os.makedirs(d, exist_ok=True)
    if isinstance(data, str):
        data = data.encode()
    with open(os.path.join(d, name), "wb") as f:
        f.write(data)

# --- protobuf, by hand (proto/swell/v1/*.proto field numbers) ---
def varint(n):
    out = b""
    while True:
        b = n & 0x7F
        n >>= 7
        if n:
            out += bytes([b | 0x80])
        else:
            return out + bytes([b])
def key(field, wt): return varint(field << 3 | wt)
def dbl(field, v): return key(field, 1) + struct.pack("<d", v)
def uint(field, v): return key(field, 0) + varint(v)
def msg(field, body): return key(field, 2) + varint(len(body)) + body
def point(field, x, z): return msg(field, dbl(1, x) + dbl(2, z))

def pb_accuracy(method=1, iterations=8, tolerance=1e-5, filt=3, precision=1, time=1):
    return uint(1, method) + uint(2, iterations) + dbl(3, tolerance) + uint(4, filt) + uint(5, precision) + uint(6, time)

def pb_sample(t=None, origin=None, points=(), fields=(), accuracy=None):
    b = b""
    if t is not None: b += dbl(1, t)
    if origin is not None: b += point(2, *origin)
    for p in points: b += point(3, *p)
    for f in fields: b += uint(4, f)
    if accuracy is not None: b += msg(5, accuracy)
    return b

def pb_body(pos, yaw, length, beam, probes=()):
    b = point(1, *pos) + dbl(2, yaw) + dbl(3, length) + dbl(4, beam)
    for p in probes: b += point(5, *p)
    return b

def pb_orientation(t=None, bodies=()):
    b = dbl(1, t) if t is not None else b""
    for body in bodies: b += msg(2, body)
    return b

# --- JSON requests ---
samples = [
    {"points": [[0, 0]]},
    {"t": 12.5, "points": [[1, 2], [-300.25, 41.5]], "fields": ["height", "normal", "displacement", "jacobian", "residual"]},
    {"t": 1e9, "origin": [1e8, -1e8], "points": [[0.5, 0.5]], "accuracy": {"method": "fixed_point", "iterations": 0, "tolerance": 0.1, "filter": "nearest", "precision": "f32", "time": "exact"}},
    {"points": [[999999999, -999999999]], "accuracy": {"method": "newton", "iterations": 64, "tolerance": 0, "filter": "bilinear", "precision": "f64", "time": "grid"}},
    {"t": -7.25, "points": [], "fields": ["jacobian"]},
]
orientations = [
    {"bodies": [{"position": [0, 0], "length": 5, "beam": 2}]},
    {"t": 3.5, "bodies": [{"position": [10, -4], "yaw": 0.7, "length": 40, "beam": 12, "probes": [[0, 0], [10, 0], [0, 5]]}]},
    {"bodies": [{"position": [0, 0], "length": 10000, "beam": 1e-3}, {"position": [1e9, 1e9], "yaw": -3.14, "length": 1, "beam": 1}]},
]
for i, s in enumerate(samples):
    write("json_sample", f"seed-{i}.json", json.dumps(s))
    write("ws_message", f"sample-{i}.json", json.dumps({"type": "sample", "id": i, **s}))
for i, o in enumerate(orientations):
    write("json_orientation", f"seed-{i}.json", json.dumps(o))
    write("ws_message", f"orientation-{i}.json", json.dumps({"type": "orientation", **o}))
write("ws_message", "ping.json", json.dumps({"type": "ping", "id": 7, "client_time": 1.5}))
write("ws_message", "subscribe.json", json.dumps({"type": "subscribe", "ticks": True, "bodies": [1, 2], "region": [-10, -10, 10, 10]}))

pb_samples = [
    pb_sample(points=[(0, 0)]),
    pb_sample(t=12.5, points=[(1, 2), (-300.25, 41.5)], fields=[1, 2, 3, 4, 5]),
    pb_sample(t=1e9, origin=(1e8, -1e8), points=[(0.5, 0.5)], accuracy=pb_accuracy(2, 0, 0.1, 1, 2, 2)),
    pb_sample(t=float("nan"), points=[(float("inf"), 0)]),
]
pb_orients = [
    pb_orientation(bodies=[pb_body((0, 0), 0, 5, 2)]),
    pb_orientation(t=3.5, bodies=[pb_body((10, -4), 0.7, 40, 12, [(0, 0), (10, 0), (0, 5)])]),
]
for i, b in enumerate(pb_samples):
    write("protobuf_request", f"sample-{i}.pb", b)
    write("ws_message", f"sample-{i}.pb", uint(1, i) + msg(3, b))
for i, b in enumerate(pb_orients):
    write("protobuf_request", f"orientation-{i}.pb", b)
    write("ws_message", f"orientation-{i}.pb", msg(4, b))
write("ws_message", "ping.pb", uint(1, 3) + msg(2, dbl(1, 2.5)))
write("ws_message", "subscribe.pb", msg(5, uint(1, 1) + uint(2, 4) + msg(3, dbl(1, -1) + dbl(2, -1) + dbl(3, 1) + dbl(4, 1))))

# --- scene specs: small versions of each layer kind (FFT grids <= 64 are built by the target) ---
specs = {
    "sine": {"description": "s", "layers": [{"kind": "sine", "waves": [{"amplitude": 0.5, "wavelength": 20, "direction": [1, 0]}]}]},
    "gerstner": {"seed": 7, "depth": 12, "layers": [{"kind": "gerstner",
        "waves": [{"amplitude": 0.25, "wavelength": 22, "direction": [1, 0.4], "steepness": 0.5}],
        "cascade": {"wavelength": 8, "amplitude": 0.08, "steepness": 0.5, "direction": [1, 0.4]}}]},
    "fft-jonswap": {"tick_hz": 60, "seed": 42, "layers": [{"kind": "fft", "resolution": 32, "tile_size": 64, "choppiness": 1.0,
        "repeat_period": 200, "wind_direction": [1, 0.3],
        "spectrum": {"kind": "jonswap", "wind_speed": 10, "fetch": 100000, "gamma": 3.3}, "spreading": {"kind": "donelan_banner"}}]},
    "fft-phillips": {"epoch": 1767225600, "depth": 3, "layers": [{"kind": "fft", "resolution": 16, "tile_size": 20, "choppiness": 2.6,
        "wind_direction": [0, -1], "band": {"min_wavelength": 1, "max_wavelength": 50}, "seed": 5,
        "spectrum": {"kind": "phillips", "wind_speed": 20, "small_wave_cutoff": 0.1}, "spreading": {"kind": "cos2s", "s": 8}}]},
    "fft-tma-gerstner": {"gravity": 9.81, "depth": 30, "layers": [
        {"kind": "fft", "resolution": 64, "tile_size": 256, "wind_direction": [1, 1],
         "spectrum": {"kind": "tma", "wind_speed": 15, "fetch": 50000}, "spreading": {"kind": "horvath", "swell": 0.5}},
        {"kind": "fft", "resolution": 16, "tile_size": 8, "wind_direction": [1, 0],
         "spectrum": {"kind": "pierson_moskowitz", "wind_speed": 5}, "spreading": {"kind": "mitsuyasu"}},
        {"kind": "gerstner", "waves": [{"amplitude": 0.6, "wavelength": 160, "direction": [0.4, 1], "steepness": 0.3}]}]},
}
for name, spec in specs.items():
    write("scene_spec", f"{name}.json", json.dumps(spec))

# --- config files: limits and scenes, as `swell serve --config` reads them ---
write("config_toml", "limits.toml", """[limits]
max_points = 1000
max_coordinate = 1e6
request_timeout_ms = 500

[scenes.pond]
description = "a pond"
tick_hz = 20
layers = [{ kind = "sine", waves = [{ amplitude = 0.1, wavelength = 5.0, direction = [1.0, 0.0] }] }]
""")
write("config_toml", "fft.toml", """[scenes.small-fft]
seed = 3
[[scenes.small-fft.layers]]
kind = "fft"
resolution = 16
tile_size = 32.0
wind_direction = [1.0, 0.5]
spectrum = { kind = "jonswap", wind_speed = 8.0, fetch = 20000.0 }
""")

# --- admin_json: one selector byte (0 clock, 1 spawn, 2 input), then the JSON body ---
admin = [
    (0, {"t": 120.5, "rate": 2.0, "paused": False}),
    (0, {"rate": -1.0}),
    (0, {"paused": True}),
    (1, {"mass": 2000.0, "hull": {"kind": "box", "length": 6.0, "beam": 2.5, "height": 1.2},
         "position": [5.0, 0.5, -3.0], "yaw": 0.3}),
    (1, {"mass": 50.0, "hull": {"kind": "cells", "cells": [
         {"position": [0.0, 0.0, 0.0], "volume": 0.2, "height": 0.5},
         {"position": [1.0, 0.0, 0.0], "volume": 0.2, "height": 0.5}]},
         "position": [0.0, 1.0, 0.0], "linear_drag": 10.0, "quadratic_drag": 2.0,
         "angular_damping": 5.0, "min_wavelength_factor": 1.5, "center_of_mass": [0.5, 0.0, 0.0]}),
    (1, {"mass": 5e5, "hull": {"kind": "box", "length": 40.0, "beam": 10.0, "height": 5.0,
         "cells": [8, 4]}, "position": [0.0, -1.0, 0.0]}),
    (2, {"force": [5000.0, 0.0, 0.0], "torque": [0.0, 800.0, 0.0], "ticks": 3}),
    (2, {"force": [0.0, 1e6, 0.0], "from_tick": 1801}),
]
for i, (which, body) in enumerate(admin):
    write("admin_json", f"seed-{i}.bin", bytes([which]) + json.dumps(body).encode())

# --- http_request: one selector byte (0 height query, 1 impacts query, 2 impact body,
# 3 WebSocket handshake), then `a` [0xFF `b`] ---
http = [
    (0, b"x=1.5&z=-2&t=3"),
    (0, b"x=one&z=%FF"),
    (1, b"t=banana"),
    (2, json.dumps({"position": [1, 2], "strength": 0.1, "radius": 1}).encode()),
    (2, json.dumps({"position": [1, 2], "t": -1e9, "strength": 0.1, "radius": 1}).encode()),
    (3, b"dGhlIHNhbXBsZSBub25jZQ==\xffswell.v1.json"),
    (3, b"not base64!\xffnope"),
]
for i, (which, rest) in enumerate(http):
    write("http_request", f"seed-{i}.bin", bytes([which]) + rest)
