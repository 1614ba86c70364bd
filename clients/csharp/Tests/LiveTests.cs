// Against a live swell (SWELL_URL; .ci/csharp-client starts one on a loopback port): HTTP,
// local evaluation and uniforms equal to the server's bits, both WebSocket subprotocols, clock
// sync through admin clock changes, tick subscriptions and interpolation.
using System;
using System.Collections.Generic;
using System.IO;
using System.Linq;
using System.Net.Http;
using System.Threading;
using System.Threading.Tasks;

namespace Swell.Tests
{
    static class Live
    {
        const double Epoch = 1767225600; // built-in scenes' epoch: t = unix − epoch at rate 1
        static readonly DateTime UnixEpoch = new DateTime(1970, 1, 1, 0, 0, 0, DateTimeKind.Utc);
        static double Wall() { return (DateTime.UtcNow - UnixEpoch).TotalSeconds; }
        static double Truth(ClockReading r) { return r.At(Wall()); }

        const string SmallSpec = "{\"description\":\"csharp clock test\",\"tick_hz\":20,\"seed\":3,\"layers\":[{\"kind\":\"gerstner\",\"waves\":[{\"amplitude\":0.4,\"wavelength\":30,\"direction\":[1,0.5],\"steepness\":0.6}]}]}";

        // With a particle layer (impacts ripple on one) for bodies to feel impacts on.
        const string ParticleSpec = "{\"description\":\"csharp impacts test\",\"tick_hz\":20,\"seed\":4,\"layers\":[{\"kind\":\"gerstner\",\"waves\":[{\"amplitude\":0.1,\"wavelength\":20,\"direction\":[1,0],\"steepness\":0.3}]},{\"kind\":\"particles\",\"count\":16,\"tile_size\":32,\"radius\":1,\"amplitude\":0.02}]}";

        internal static void Run(string url, string token, string vectors)
        {
            var http = new SwellClient(url, token);
            var points = new List<double[]> { new[] { 0.0, 0 }, new[] { 13.7, -4.2 }, new[] { -250.5, 999.25 }, new[] { 1e6 + 0.125, -3e5 }, new[] { -7.75, 1234.5 } };

            Runner.TA("HTTP: scenes, scene detail, clock, errors as SwellException", async () =>
            {
                var scenes = Json.List(await http.Scenes(), "scenes");
                Runner.Assert(scenes.Any(s => Json.Str(s, "id") == "calm"), "calm is listed");
                var c = await http.Clock("calm");
                Runner.Assert(Math.Abs(c.T - (c.Unix - Epoch)) < 1e-3 && c.Generation >= 0, "calm's clock is wall-anchored, with a generation");
                try
                {
                    await http.Sample("calm", points, -1e12);
                    Runner.Assert(false, "no error");
                }
                catch (SwellException e)
                {
                    Runner.Equal(400, e.Status, "status");
                    Runner.Equal("invalid_value", e.Code, "code");
                    Runner.Assert(e.Field == "t", "field " + e.Field);
                }
                var hlsl = await http.Shader("calm", "hlsl_include");
                Runner.Assert(hlsl.Contains("swell"), "an HLSL include");
            });

            foreach (var scene in new[] { "calm", "lake" })
            {
                Runner.TA(scene + ": local evaluation equals /sample bit for bit at the scene's now", async () =>
                {
                    var surface = Surface.FromDerived(Json.Get(await http.Scene(scene), "derived"));
                    var c = await http.Clock(scene);
                    foreach (var t in new[] { c.T, c.T + 0.5, 12.345 })
                    {
                        var server = await http.Sample(scene, points, t, new[] { "height", "normal", "displacement", "jacobian", "residual" });
                        for (int i = 0; i < points.Count; i++)
                        {
                            var q = surface.Query(points[i][0], points[i][1], t);
                            string w = scene + " t=" + t + " point " + i;
                            Runner.Equal(Bits(Json.List(server, "height")[i]), SwellMath.BitsHex(q.Height), w + " height");
                            var n = Json.Nums(Json.List(server, "normal")[i]);
                            var d = Json.Nums(Json.List(server, "displacement")[i]);
                            for (int k = 0; k < 3; k++)
                            {
                                Runner.Equal(SwellMath.BitsHex(n[k]), SwellMath.BitsHex(q.Normal[k]), w + " normal");
                                Runner.Equal(SwellMath.BitsHex(d[k]), SwellMath.BitsHex(q.Displacement[k]), w + " displacement");
                            }
                            Runner.Equal(Bits(Json.List(server, "jacobian")[i]), SwellMath.BitsHex(q.Jacobian), w + " jacobian");
                            Runner.Equal(Bits(Json.List(server, "residual")[i]), SwellMath.BitsHex(q.Residual), w + " residual");
                        }
                    }
                });

                Runner.TA(scene + ": frame uniforms computed locally equal GET /uniforms", async () =>
                {
                    var surface = Surface.FromDerived(Json.Get(await http.Scene(scene), "derived"));
                    var c = await http.Clock(scene);
                    foreach (var o in new[] { new[] { 0.0, 0 }, new[] { 1e6 + 0.5, -2.5e5 } })
                    {
                        var server = await http.Uniforms(scene, c.T, o[0], o[1]);
                        var local = surface.Uniforms(c.T, o[0], o[1]);
                        var phases = Json.Nums(Json.Get(server, "phases"));
                        var block = Json.Nums(Json.Get(server, "block"));
                        Runner.Equal(phases.Length, local.Phases.Length, "waves");
                        for (int i = 0; i < phases.Length; i++) Runner.Equal(SwellMath.BitsHex(phases[i]), SwellMath.BitsHex(local.Phases[i]), "phase " + i);
                        Runner.Equal(block.Length, local.Block.Length, "block length");
                        for (int i = 0; i < block.Length; i++) Runner.Equal((float)block[i], local.Block[i], "block " + i);
                    }
                });
            }

            Runner.TA("open-sea (FFT + Gerstner): local uniforms equal GET /uniforms, FFT grid offsets included", async () =>
            {
                var surface = Surface.FromDerived(Json.Get(await http.Scene("open-sea"), "derived"));
                Runner.Assert(!surface.Analytic, "FFT layers are not analytic");
                var c = await http.Clock("open-sea");
                foreach (var o in new[] { new[] { 0.0, 0 }, new[] { -1234.75, 98765.5 } })
                {
                    var server = await http.Uniforms("open-sea", c.T, o[0], o[1]);
                    var local = surface.Uniforms(c.T, o[0], o[1]);
                    var phases = Json.Nums(Json.Get(server, "phases"));
                    var block = Json.Nums(Json.Get(server, "block"));
                    for (int i = 0; i < phases.Length; i++) Runner.Equal(SwellMath.BitsHex(phases[i]), SwellMath.BitsHex(local.Phases[i]), "phase " + i);
                    Runner.Equal(block.Length, local.Block.Length, "block length");
                    for (int i = 0; i < block.Length; i++) Runner.Equal((float)block[i], local.Block[i], "block " + i);
                    Runner.Assert(local.Block.Length > local.PhaseSlots, "FFT vec4s after the phases");
                }
            });

            // FFT layers evaluated here (FftLayer.cs, from the exported spectrum): within
            // FftTolerance of the server (other butterflies, so not bit for bit).
            Runner.TA("open-sea and storm: without an FftLayer the surface refuses; with one, local queries within 1e-9 m of /sample", async () =>
            {
                foreach (var scene in new[] { "open-sea", "storm" })
                {
                    var derived = Json.Get(await http.Scene(scene), "derived");
                    var bare = Surface.FromDerived(derived);
                    Runner.Assert(!bare.CanSample, scene + ": no evaluator, no local sampling");
                    try { bare.Height(0, 0, 0); Runner.Assert(false, "no exception"); }
                    catch (NotSupportedException e) { Runner.Assert(e.Message.Contains("FftLayer"), e.Message); }
                    var surface = await WithFft(http, scene, derived);
                    Runner.Assert(surface.CanSample, scene + ": evaluates locally");
                    try { surface.Height(0, 0, double.NaN); Runner.Assert(false, "a NaN time was taken"); }
                    catch (ArgumentException) { }
                    Runner.Assert(double.IsNaN(surface.Height(double.NaN, 0, 1)), "a NaN point gives NaN");
                    var c = await http.Clock(scene);
                    // The first query computes the two grid frames around its time.
                    var watch = System.Diagnostics.Stopwatch.StartNew();
                    surface.Height(3.5, -2.25, 1000.01);
                    double cold = watch.Elapsed.TotalMilliseconds;
                    watch.Restart();
                    for (int i = 0; i < 10000; i++) surface.Height(-7.5 + 0.01 * i, 4.75, 1000.01);
                    Console.WriteLine("     " + scene + ": first height (two frames) " + cold.ToString("f1") + " ms, then " + (watch.Elapsed.TotalMilliseconds * 0.1).ToString("f2") + " us a height (10,000 at that time)");
                    double worst = 0;
                    foreach (var t in new[] { c.T, c.T + 0.37, 12.345, 86400.25 })
                    {
                        var server = await http.Sample(scene, points, t, new[] { "height", "normal", "displacement", "jacobian", "residual" });
                        for (int i = 0; i < points.Count; i++)
                            worst = Math.Max(worst, Differs(surface.Query(points[i][0], points[i][1], t), server, i, scene + " t=" + t + " point " + i));
                    }
                    Console.WriteLine("     " + scene + ": largest difference to /sample " + worst.ToString("e2"));
                }
            });

            Runner.TA("golden FFT cases: every field within 1e-9 m of the vector, with the spectrum the server exports", async () =>
            {
                object doc = Json.Parse(File.ReadAllText(Path.Combine(vectors, "surface_v1.json")));
                int cases = 0;
                foreach (var c in Json.List(doc, "cases"))
                {
                    var spec = (Dictionary<string, object>)Json.Get(c, "spec");
                    if (!Json.List(spec, "layers").Any(l => Json.Str(l, "kind") == "fft")) continue;
                    spec["description"] = "golden";
                    string name = Json.Str(c, "name");
                    string id = ("golden-cs-" + name.Replace('_', '-'));
                    if (id.Length > 64) id = id.Substring(0, 64);
                    var detail = await http.PutScene(id, spec);
                    var surface = await WithFft(http, id, Json.Get(detail, "derived"));
                    double worst;
                    int n = Offline.CheckCase(surface, c, FftTolerance, out worst);
                    Runner.Assert(n > 0, name + ": no points");
                    Console.WriteLine("     golden " + name + ": " + n + " time x point, largest difference " + worst.ToString("e2"));
                    cases++;
                }
                Runner.Assert(cases >= 2, "FFT cases in the vectors: " + cases);
            });

            Runner.TA("golden lake_gerstner_cascade bit for bit from the server-built cascade waves", async () =>
            {
                object doc = Json.Parse(File.ReadAllText(Path.Combine(vectors, "surface_v1.json")));
                var c = Json.List(doc, "cases").First(k => Json.Str(k, "name") == "lake_gerstner_cascade");
                var spec = (Dictionary<string, object>)Json.Get(c, "spec");
                spec["description"] = "golden";
                var detail = await http.PutScene("golden-lake-cs", spec);
                int n = Offline.CheckCase(Surface.FromDerived(Json.Get(detail, "derived")), c);
                Runner.Equal(20, n, "points");
            });

            foreach (var wire in new[] { Wire.Json, Wire.Protobuf })
            {
                Runner.TA("WebSocket " + wire + ": clock sync within 5 ms of the wall-anchored clock", async () =>
                {
                    using (var s = new SwellSession(http.StreamUrl("calm"), wire) { PingIntervalMs = 100, SyncPings = 10 })
                    {
                        await s.ConnectAsync();
                        await Task.Delay(300);
                        double err = s.ServerTime() - (Wall() - Epoch);
                        Console.WriteLine("     clock sync (" + wire + "): error " + (err * 1e3).ToString("F3") + " ms, min RTT " + (s.Clock.MinRtt * 1e3).ToString("F3") + " ms");
                        Runner.Assert(Math.Abs(err) < 0.005, "off by " + err + " s");
                        await s.CloseAsync();
                    }
                });

                Runner.TA("WebSocket " + wire + ": seek and rate change while connected, within 5 ms 1 s after each", async () =>
                {
                    string id = "clock-cs-" + wire.ToString().ToLowerInvariant();
                    await http.PutScene(id, Json.Parse(SmallSpec));
                    var events = new List<ClockReading>();
                    using (var s = new SwellSession(http.StreamUrl(id), wire))
                    {
                        s.OnClock += e => { lock (events) events.Add(e); };
                        await s.ConnectAsync();
                        var changes = new[]
                        {
                            Tuple.Create("seek", (double?)118000.0, (double?)null, (bool?)null),
                            Tuple.Create("rate 1 -> 2", (double?)null, (double?)2.0, (bool?)null),
                            Tuple.Create("pause", (double?)null, (double?)null, (bool?)true),
                            Tuple.Create("resume", (double?)null, (double?)null, (bool?)false),
                            Tuple.Create("seek back, rate -1", (double?)50.0, (double?)-1.0, (bool?)null),
                        };
                        foreach (var ch in changes)
                        {
                            long before = s.Clock.Clock.Generation;
                            var r = await http.SetClock(id, ch.Item2, ch.Item3, ch.Item4);
                            Runner.Equal(before + 1, r.Generation, ch.Item1 + ": one generation per change");
                            await Task.Delay(1000);
                            double err = s.ServerTime() - Truth(r);
                            Console.WriteLine("     clock change (" + wire + ", " + ch.Item1 + "): error 1 s after " + (err * 1e3).ToString("F3") + " ms");
                            Runner.Assert(Math.Abs(err) < 0.005, ch.Item1 + ": off by " + err + " s 1 s after the change");
                            Runner.Equal(r.Generation, s.Clock.Clock.Generation, ch.Item1 + ": the fit's generation");
                            lock (events) Runner.Equal(r.Generation, events.Last().Generation, ch.Item1 + ": a clock event");
                        }
                        await s.CloseAsync();
                    }
                });

                Runner.TA("WebSocket " + wire + ": joining a paused or rate-2 scene, within 5 ms after the first pong", async () =>
                {
                    string id = "clock-join-cs-" + wire.ToString().ToLowerInvariant();
                    await http.PutScene(id, Json.Parse(SmallSpec));
                    foreach (var paused in new[] { true, false })
                    {
                        var r = paused ? await http.SetClock(id, 777.25, null, true) : await http.SetClock(id, null, 2.0, false);
                        using (var s = new SwellSession(http.StreamUrl(id), wire) { SyncPings = 1 })
                        {
                            await s.ConnectAsync();
                            double err = s.ServerTime() - Truth(r);
                            Console.WriteLine("     joining a " + (paused ? "paused" : "rate-2") + " scene (" + wire + "): error after the first pong " + (err * 1e3).ToString("F3") + " ms");
                            Runner.Assert(Math.Abs(err) < 0.005, "off by " + err + " s");
                            Runner.Equal(1, s.Clock.Count, "one sample");
                            await s.CloseAsync();
                        }
                    }
                });

                Runner.TA("WebSocket " + wire + ": subscribe by ids and region; interpolation between frames", async () =>
                {
                    string id = "bodies-cs-" + wire.ToString().ToLowerInvariant();
                    await http.PutScene(id, Json.Parse(SmallSpec));
                    var hull = Json.Parse("{\"kind\":\"box\",\"length\":8,\"beam\":3,\"height\":1.5}");
                    var a = await http.SpawnBody(id, new Dictionary<string, object> { { "mass", 3000.0 }, { "hull", hull }, { "position", new[] { 0.0, 0.5, 0 } } });
                    var b = await http.SpawnBody(id, new Dictionary<string, object> { { "mass", 3000.0 }, { "hull", hull }, { "position", new[] { 100.0, 0.5, 100 } } });
                    ulong ida = (ulong)Json.Num(a, "id"), idb = (ulong)Json.Num(b, "id");
                    var frames = new List<TickFrame>();
                    var ip = new BodyInterpolator();
                    using (var s = new SwellSession(http.StreamUrl(id), wire) { Interpolator = ip })
                    {
                        s.OnTick += f => { lock (frames) frames.Add(f); };
                        await s.ConnectAsync();
                        await s.Subscribe(new[] { ida });
                        var f1 = await Next(frames, f => f.Bodies.Count > 0);
                        Runner.Equal(ida, f1.Bodies.Single().Id, "by id");
                        Runner.Equal(f1.Tick / 20.0, f1.T, "t is the tick's start");
                        Runner.Equal(Json.Num(a, "anchor_tick"), (double)f1.AnchorTick.Value, "the body world's anchor, as the spawn answered");
                        await s.Subscribe(new ulong[0], new[] { 50.0, 50, 150, 150 });
                        await Task.Delay(200);
                        lock (frames) frames.Clear();
                        var f2 = await Next(frames, f => true);
                        Runner.Equal(idb, f2.Bodies.Single().Id, "by region");
                        await s.Subscribe();
                        await Task.Delay(600);
                        var at = ip.At(s.ServerTime());
                        Runner.Assert(at.ContainsKey(ida) && at.ContainsKey(idb), "both bodies");
                        Runner.Equal(InterpMode.Interpolated, at[ida].Mode, "rendered 0.1 s behind: between two frames");
                        double tt = s.ServerTime() - ip.Delay;
                        lock (frames)
                        {
                            var before = frames.Last(f => f.T <= tt && f.Bodies.Any(x => x.Id == ida));
                            var after = frames.First(f => f.T > tt && f.Bodies.Any(x => x.Id == ida));
                            double u = (at[ida].T - before.T) / (after.T - before.T);
                            double y0 = before.Bodies.First(x => x.Id == ida).Position[1], y1 = after.Bodies.First(x => x.Id == ida).Position[1];
                            Runner.Assert(u >= 0 && u <= 1, "between the frames around it: u = " + u);
                            Runner.Assert(Math.Abs(at[ida].Position[1] - (y0 + (y1 - y0) * u)) < 1e-12, "the lerp of the frames around it");
                        }
                        await s.Unsubscribe();
                        await s.CloseAsync();
                    }
                });

                Runner.TA("WebSocket " + wire + ": a tick frame carries each API impact with the POST answer's body tick", async () =>
                {
                    string id = "felt-cs-" + wire.ToString().ToLowerInvariant();
                    await http.PutScene(id, Json.Parse(ParticleSpec));
                    var hull = Json.Parse("{\"kind\":\"box\",\"length\":8,\"beam\":3,\"height\":1.5}");
                    await http.SpawnBody(id, new Dictionary<string, object> { { "mass", 3000.0 }, { "hull", hull }, { "position", new[] { 0.0, 0.4, 0 } } });
                    var frames = new List<TickFrame>();
                    using (var s = new SwellSession(http.StreamUrl(id), wire))
                    {
                        s.OnTick += f => { lock (frames) frames.Add(f); };
                        await s.ConnectAsync();
                        await s.Subscribe();
                        await Next(frames, f => true);
                        var impact = new Dictionary<string, object> { { "position", new[] { 2.0, 1.0 } }, { "strength", 0.5 }, { "radius", 1.0 } };
                        var answer = await http.RequestJson(HttpMethod.Post, "/v1/scenes/" + id + "/impacts", impact, true);
                        Runner.Assert(Json.Get(answer, "body_tick") is double, "the answer has a body_tick: " + Json.Write(answer));
                        double t = Json.Num(answer, "t");
                        var carrying = await Next(frames, f => f.Impacts.Any(e => e.T == t));
                        var e0 = carrying.Impacts.First(e => e.T == t);
                        Runner.Assert(e0.BodyTick.HasValue, "the frame's impact has a body tick");
                        Runner.Equal(Json.Num(answer, "body_tick"), (double)e0.BodyTick.Value, "the body tick the POST answered");
                        Runner.Equal(Json.Num(answer, "tick"), (double)e0.Tick, "the tick the POST answered");
                        Runner.Equal(2.0, e0.Position[0], "x");
                        Runner.Equal(1.0, e0.Position[1], "z");
                        await s.CloseAsync();
                    }
                });

                Runner.TA("WebSocket " + wire + ": a scene deleted under a subscriber: OnError not_found, Closed with 4404", async () =>
                {
                    string id = "doomed-cs-" + wire.ToString().ToLowerInvariant();
                    await http.PutScene(id, Json.Parse(SmallSpec));
                    var frames = new List<TickFrame>();
                    var errors = new List<SwellException>();
                    var closed = new TaskCompletionSource<bool>();
                    using (var s = new SwellSession(http.StreamUrl(id), wire))
                    {
                        s.OnTick += f => { lock (frames) frames.Add(f); };
                        s.OnError += e => { lock (errors) errors.Add(e); };
                        s.Closed += () => closed.TrySetResult(true);
                        await s.ConnectAsync();
                        await s.Subscribe();
                        await Next(frames, f => true);
                        await http.DeleteScene(id);
                        var done = await Task.WhenAny(closed.Task, Task.Delay(5000));
                        Runner.Assert(done == closed.Task, "Closed fired");
                        Runner.Equal(SwellSession.SceneGone, s.CloseStatus ?? -1, "close status");
                        Runner.Assert(s.CloseReason.Contains(id), "reason: " + s.CloseReason);
                        lock (errors) Runner.Assert(errors.Any(e => e.Code == "not_found"), "OnError heard not_found");
                    }
                    using (var s = new SwellSession(http.StreamUrl(id), wire))
                    {
                        try
                        {
                            await s.ConnectAsync();
                            Runner.Assert(false, "connected to a deleted scene");
                        }
                        catch (SwellException e)
                        {
                            Runner.Equal("unreachable", e.Code, "code");
                        }
                    }
                });
            }
        }

        static string Bits(object v) { return SwellMath.BitsHex((double)v); }

        /// <summary>How far the managed FFT evaluation may be from the server (docs/clients.md): measured ~1e-15 to ~1e-14 m.</summary>
        const double FftTolerance = 1e-9;

        /// <summary>The scene's surface with an FftLayer for each FFT layer, from its exported spectrum.</summary>
        static async Task<Surface> WithFft(SwellClient http, string scene, object derived)
        {
            var layers = Json.List(derived, "layers");
            var fft = new FftLayer[layers.Count];
            for (int i = 0; i < layers.Count; i++)
                if (Json.Str(layers[i], "kind") == "fft") fft[i] = new FftLayer(FftSpectrum.Parse(await http.Spectrum(scene, i)));
            return Surface.FromDerived(derived, fft);
        }

        /// <summary>The largest difference between a local query and point i of a /sample answer; each field within FftTolerance.</summary>
        static double Differs(SurfaceQuery q, object server, int i, string where)
        {
            double d = Math.Abs(q.Height - (double)Json.List(server, "height")[i]);
            var n = Json.Nums(Json.List(server, "normal")[i]);
            var disp = Json.Nums(Json.List(server, "displacement")[i]);
            for (int k = 0; k < 3; k++)
            {
                d = Math.Max(d, Math.Abs(q.Normal[k] - n[k]));
                d = Math.Max(d, Math.Abs(q.Displacement[k] - disp[k]));
            }
            d = Math.Max(d, Math.Abs(q.Jacobian - (double)Json.List(server, "jacobian")[i]));
            d = Math.Max(d, Math.Abs(q.Residual - (double)Json.List(server, "residual")[i]));
            Runner.Assert(d <= FftTolerance, where + ": " + d);
            return d;
        }

        static async Task<TickFrame> Next(List<TickFrame> frames, Func<TickFrame, bool> pred)
        {
            for (int i = 0; i < 250; i++)
            {
                lock (frames)
                {
                    var f = frames.FirstOrDefault(pred);
                    if (f != null) return f;
                }
                await Task.Delay(20);
            }
            throw new Exception("no matching tick frame");
        }
    }
}
