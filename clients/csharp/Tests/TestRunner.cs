// The package's tests, as one console program with a tiny runner (no NUnit needed): golden
// vectors bit for bit, clock sync and interpolation offline, and, when SWELL_URL names a live
// server (.ci/csharp-client starts one), HTTP, both WebSocket subprotocols, clock changes and
// interpolation against it.
//
// Usage: mono SwellTests.exe [path/to/proto/vectors]   (env SWELL_URL, SWELL_TOKEN)
using System;
using System.Collections.Generic;
using System.IO;
using System.Linq;
using System.Text;
using System.Threading;
using System.Threading.Tasks;

namespace Swell.Tests
{
    static class Runner
    {
        static int passed, failed;
        static readonly List<string> Failures = new List<string>();

        static void Test(string name, Action body)
        {
            var sw = System.Diagnostics.Stopwatch.StartNew();
            try
            {
                body();
                passed++;
                Console.WriteLine("ok   " + name + " (" + sw.ElapsedMilliseconds + " ms)");
            }
            catch (Exception e)
            {
                var inner = e is AggregateException ? ((AggregateException)e).Flatten().InnerException : e;
                failed++;
                Failures.Add(name + ": " + inner);
                Console.WriteLine("FAIL " + name + ": " + inner.Message);
            }
        }

        static void TestAsync(string name, Func<Task> body)
        {
            Test(name, () => body().GetAwaiter().GetResult());
        }

        internal static void Assert(bool ok, string what)
        {
            if (!ok) throw new Exception("assertion failed: " + what);
        }

        internal static void Equal<T>(T want, T got, string what)
        {
            if (!EqualityComparer<T>.Default.Equals(want, got)) throw new Exception(what + ": want " + want + ", got " + got);
        }

        static int Main(string[] args)
        {
            string vectors = args.Length > 0 ? args[0] : Path.Combine("..", "..", "proto", "vectors");
            Offline.Run(vectors);
            if (Environment.GetEnvironmentVariable("SWELL_NATIVE") == "1") NativeTests.Run(vectors);
            else Console.WriteLine("skip native tests: SWELL_NATIVE is not 1 (needs libswell_ffi on the library path)");
            string url = Environment.GetEnvironmentVariable("SWELL_URL");
            if (!string.IsNullOrEmpty(url)) Live.Run(url, Environment.GetEnvironmentVariable("SWELL_TOKEN"), vectors);
            else Console.WriteLine("skip live tests: SWELL_URL is not set");
            Console.WriteLine(passed + " passed, " + failed + " failed");
            foreach (var f in Failures) Console.WriteLine("  " + f);
            return failed == 0 ? 0 : 1;
        }

        internal static void T(string name, Action body) { Test(name, body); }
        internal static void TA(string name, Func<Task> body) { TestAsync(name, body); }
    }

    static class Offline
    {
        internal static void Run(string vectors)
        {
            object doc = Json.Parse(File.ReadAllText(Path.Combine(vectors, "surface_v1.json")));
            Runner.T("golden vectors: model version 3", () => Runner.Equal(3.0, Json.Num(doc, "model_version"), "model_version"));
            foreach (var name in new[] { "calm_sine", "steep_gerstner_s095" })
            {
                Runner.T("golden " + name + ": every field bit for bit", () =>
                {
                    var c = Json.List(doc, "cases").First(k => Json.Str(k, "name") == name);
                    int n = CheckCase(Surface.FromSpec(Json.Get(c, "spec")), c);
                    Runner.Equal(Json.List(c, "times").Count * Json.List(c, "points").Count, n, "points checked");
                });
            }

            Runner.T("FftLayer.InverseFft2 equals a direct inverse DFT", () =>
            {
                int n = 16;
                var re = new double[n * n];
                var im = new double[n * n];
                for (int i = 0; i < n * n; i++) { re[i] = Math.Sin(i * 1.37) * 0.3; im[i] = Math.Cos(i * 0.71) * 0.2; }
                var r0 = (double[])re.Clone();
                var i0 = (double[])im.Clone();
                FftLayer.InverseFft2(re, im, n);
                double err = 0;
                for (int q = 0; q < n; q++)
                    for (int p = 0; p < n; p++)
                    {
                        double sr = 0, si = 0;
                        for (int j = 0; j < n; j++)
                            for (int i = 0; i < n; i++)
                            {
                                double a = 2 * Math.PI * (i * p + j * q) / n;
                                sr += r0[j * n + i] * Math.Cos(a) - i0[j * n + i] * Math.Sin(a);
                                si += r0[j * n + i] * Math.Sin(a) + i0[j * n + i] * Math.Cos(a);
                            }
                        err = Math.Max(err, Math.Max(Math.Abs(sr - re[q * n + p]), Math.Abs(si - im[q * n + p])));
                    }
                Runner.Assert(err < 1e-12, "largest difference " + err);
            });

            Runner.T("FftSpectrum.Parse refuses what is not a spectrum export", () =>
            {
                foreach (var bad in new[] { new byte[0], Encoding.ASCII.GetBytes("NOPE\u0002\0\0\0{}"), Encoding.ASCII.GetBytes("SWSP\u00ff\0\0\0{}") })
                {
                    try { FftSpectrum.Parse(bad); Runner.Assert(false, "parsed " + bad.Length + " bytes"); }
                    catch (FormatException) { }
                }
            });

            Runner.T("sin/cos kernel: known values and odd/even symmetry", () =>
            {
                double s, c;
                SwellMath.SinCos(0, out s, out c);
                Runner.Equal(0.0, s, "sin 0");
                Runner.Equal(1.0, c, "cos 0");
                for (double x = -40; x < 40; x += 0.37)
                {
                    double s2, c2;
                    SwellMath.SinCos(x, out s, out c);
                    SwellMath.SinCos(-x, out s2, out c2);
                    Runner.Assert(Math.Abs(s - Math.Sin(x)) < 1e-15 && Math.Abs(c - Math.Cos(x)) < 1e-15, "close to Math.Sin at " + x);
                }
            });

            Runner.T("JSON numbers read to the nearest double (Mono's double.Parse does not, 1 in ~3,600)", () =>
            {
                // Shortest forms another runtime's double.Parse read one ulp off (found against
                // Python's correctly rounded float()); the bits are the nearest doubles.
                Runner.Equal(unchecked((long)0xc0045dd1ee5e85c5UL), BitConverter.DoubleToInt64Bits(Json.ParseDouble("-2.545810568103408")), "-2.545810568103408");
                Runner.Equal(unchecked((long)0xbfe9228e8fbf8561UL), BitConverter.DoubleToInt64Bits(Json.ParseDouble("-0.78546836925322")), "-0.78546836925322");
                Runner.Equal(unchecked((long)0xc005d97c779cd70dUL), BitConverter.DoubleToInt64Bits(Json.ParseDouble("-2.731194433664206")), "-2.731194433664206");
                // Ties to even, subnormals, binade edges, exponents.
                Runner.Equal(BitConverter.DoubleToInt64Bits(9007199254740992.0), BitConverter.DoubleToInt64Bits(Json.ParseDouble("9007199254740993")), "2^53 + 1 (tie, to even)");
                Runner.Equal(BitConverter.DoubleToInt64Bits(9007199254740996.0), BitConverter.DoubleToInt64Bits(Json.ParseDouble("9007199254740995")), "2^53 + 3 (tie, to even)");
                Runner.Equal(1L, BitConverter.DoubleToInt64Bits(Json.ParseDouble("4.9406564584124654e-324")), "least subnormal");
                Runner.Equal(BitConverter.DoubleToInt64Bits(1.0), BitConverter.DoubleToInt64Bits(Json.ParseDouble("1.00000000000000011102230246251565404236316680908203125")), "1 + half an ulp (tie, to even)");
                Runner.Equal(BitConverter.DoubleToInt64Bits(1e300), BitConverter.DoubleToInt64Bits(Json.ParseDouble("1E300")), "1E300");
                // What Json.Number writes reads back, over magnitudes the wire carries.
                var rng = new Random(28);
                for (int i = 0; i < 100000; i++)
                {
                    double x = (rng.NextDouble() * 2 - 1) * Math.PI * Math.Pow(10, rng.Next(-8, 9));
                    string r = Json.Number(x);
                    Runner.Equal(BitConverter.DoubleToInt64Bits(x), BitConverter.DoubleToInt64Bits(Json.ParseDouble(r)), r);
                }
            });

            Runner.T("JSON numbers round-trip to the bit", () =>
            {
                var rng = new Random(5);
                for (int i = 0; i < 20000; i++)
                {
                    double x = BitConverter.Int64BitsToDouble((long)(rng.NextDouble() * long.MaxValue));
                    if (double.IsNaN(x) || double.IsInfinity(x)) continue;
                    double y = (double)Json.Parse(Json.Number(x));
                    Runner.Equal(BitConverter.DoubleToInt64Bits(x), BitConverter.DoubleToInt64Bits(y), "bits of " + x);
                }
            });

            Runner.T("ClockSync: rate 2 from one sample; paused holds; drift fit at rate 1", () =>
            {
                var c = new ClockSync(new ClockState { Rate = 2, Generation = 1 });
                // Scene = 1000 + 2·client; one-way 1 ms each way.
                c.Add(10.0, 10.002, 1000 + 2 * 10.001);
                Runner.Assert(Math.Abs(c.SceneTime(20) - (1000 + 40)) < 1e-9, "rate 2: " + c.SceneTime(20));
                var p = new ClockSync(new ClockState { Rate = 1, Paused = true, Generation = 2 });
                p.Add(1, 1.004, 77.25);
                Runner.Equal(77.25, p.SceneTime(500), "paused");
                var d = new ClockSync(new ClockState { Rate = 1, Generation = 0 });
                double drift = 2e-4;
                for (int i = 0; i < 60; i++) d.Add(i * 0.1, i * 0.1 + 0.002, 500 + (1 + drift) * (i * 0.1 + 0.001));
                Runner.Assert(Math.Abs(d.Drift - drift) < 2e-5, "drift " + d.Drift);
                Runner.Assert(Math.Abs(d.SceneTime(30) - (500 + (1 + drift) * 30)) < 1e-3, "at 30 s");
            });

            Runner.T("ClockSync leaves a held-up round trip out of the offset, even with only a few samples", () =>
            {
                // Just after a change to rate 2: three samples, the third held up 30 ms on its way
                // back, so its midpoint is 15 ms after the server read the clock.
                Func<double, double> scene = x => 1000 + 2 * x;
                var c = new ClockSync(new ClockState { Rate = 2, Generation = 1 });
                c.Add(10.0, 10.0002, scene(10.0001));
                c.Add(10.1, 10.1002, scene(10.1001));
                c.Add(10.2, 10.2302, scene(10.2001));
                Runner.Assert(Math.Abs(c.SceneTime(11) - scene(11)) < 1e-9, "off by " + (c.SceneTime(11) - scene(11)));
            });

            Runner.T("BodyInterpolator: interpolates, extrapolates, holds, resets on a jump back", () =>
            {
                var ip = new BodyInterpolator(0.1, 64, 0.25);
                for (int k = 0; k < 5; k++)
                {
                    var f = new TickFrame { Tick = k, T = k / 10.0 };
                    f.Bodies.Add(new BodyState { Id = 7, Position = new[] { k * 1.0, 0, 0 }, Velocity = new[] { 10.0, 0, 0 } });
                    ip.Push(f);
                }
                var a = ip.Sample(0.25)[7];
                Runner.Equal(InterpMode.Interpolated, a.Mode, "mode");
                Runner.Assert(Math.Abs(a.Position[0] - 2.5) < 1e-12, "x " + a.Position[0]);
                var e = ip.Sample(0.5)[7];
                Runner.Equal(InterpMode.Extrapolated, e.Mode, "past the newest");
                Runner.Assert(Math.Abs(e.Position[0] - 5.0) < 1e-12, "extrapolated x " + e.Position[0]);
                Runner.Equal(InterpMode.Held, ip.Sample(2.0)[7].Mode, "too far");
                Runner.Equal(InterpMode.Held, ip.Sample(-1)[7].Mode, "before");
                Runner.Assert(Math.Abs(ip.At(0.4)[7].Position[0] - 3.0) < 1e-12, "At = Sample(t - delay)");
                ip.Push(new TickFrame { Tick = 1, T = 0.1 });
                Runner.Equal(1, ip.Count, "reset on a frame older than the newest");
            });

            Runner.T("protobuf: ping and subscribe encode as prost does; a pong decodes", () =>
            {
                // ClientMessage{id: 3, ping{client_time: 1.5}}: 08 03 12 09 09 <1.5 LE>.
                var ping = Protobuf.Ping(3, 1.5);
                Runner.Equal("0803120909000000000000f83f", Hex(ping), "ping bytes");
                var sub = Protobuf.Subscribe(4, true, new ulong[] { 1, 300 }, null);
                Runner.Equal("08042a070801120301ac02", Hex(sub), "subscribe bytes");
                // ServerMessage{id: 9, pong{client_time 4, scene_time 2.5, tick 75, rate 2, paused, generation 5}}.
                var pong = FromHex("0809" + "1221" + "090000000000001040" + "110000000000000440" + "184b" + "210000000000000040" + "2801" + "3005");
                var m = Protobuf.Decode(pong);
                Runner.Equal("pong", m.Type, "type");
                Runner.Equal(9UL, m.Id, "id");
                Runner.Equal(2.5, m.SceneTime, "scene_time");
                Runner.Equal(75L, m.Tick, "tick");
                Runner.Equal(2.0, m.Clock.Rate, "rate");
                Runner.Equal(true, m.Clock.Paused, "paused");
                Runner.Equal(5L, m.Clock.Generation, "generation");
            });
        }

        internal static string Hex(byte[] b) { return string.Concat(b.Select(x => x.ToString("x2"))); }

        static byte[] FromHex(string h)
        {
            var b = new byte[h.Length / 2];
            for (int i = 0; i < b.Length; i++) b[i] = Convert.ToByte(h.Substring(2 * i, 2), 16);
            return b;
        }

        internal static int CheckCase(Surface surface, object c)
        {
            double worst;
            return CheckCase(surface, c, 0, out worst);
        }

        /// <summary>
        /// Every expected point of golden case c: bit for bit when tolerance is 0, else each field
        /// within tolerance (worst: the largest difference). Returns the points checked.
        /// </summary>
        internal static int CheckCase(Surface surface, object c, double tolerance, out double worst)
        {
            int n = 0;
            worst = 0;
            foreach (var e in Json.List(c, "expected"))
            {
                var pt = Json.Nums(Json.Get(e, "point"));
                double t = Json.Num(e, "t");
                var q = surface.Query(pt[0], pt[1], t);
                var bits = Json.Get(e, "bits");
                string where = Json.Str(c, "name") + " t=" + t + " point=" + pt[0] + "," + pt[1];
                var nb = Json.List(bits, "normal");
                var db = Json.List(bits, "displacement");
                var fields = new List<KeyValuePair<string, double>>
                {
                    new KeyValuePair<string, double>(Json.Str(bits, "height"), q.Height),
                    new KeyValuePair<string, double>(Json.Str(bits, "jacobian"), q.Jacobian),
                    new KeyValuePair<string, double>(Json.Str(bits, "residual"), q.Residual),
                };
                for (int k = 0; k < 3; k++)
                {
                    fields.Add(new KeyValuePair<string, double>((string)nb[k], q.Normal[k]));
                    fields.Add(new KeyValuePair<string, double>((string)db[k], q.Displacement[k]));
                }
                string[] names = { "height", "jacobian", "residual", "normal[0]", "displacement[0]", "normal[1]", "displacement[1]", "normal[2]", "displacement[2]" };
                for (int f = 0; f < fields.Count; f++)
                {
                    if (tolerance == 0)
                    {
                        Runner.Equal(fields[f].Key, SwellMath.BitsHex(fields[f].Value), where + " " + names[f]);
                        continue;
                    }
                    double d = Math.Abs(fields[f].Value - SwellMath.FromBitsHex(fields[f].Key));
                    Runner.Assert(d <= tolerance, where + " " + names[f] + ": " + d);
                    worst = Math.Max(worst, d);
                }
                Runner.Equal(Json.Bool(bits, "folded", false), q.Folded, where + " folded");
                n++;
            }
            return n;
        }
    }
}
