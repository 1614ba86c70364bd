// Local evaluation of a scene's sine and Gerstner layers, to the server's bits: a port of
// clients/js/src/surface.js (itself a port of crates/swell-waves wave.rs, surface.rs, query.rs).
// Every operation is a correctly rounded IEEE double operation in the model's order; the golden
// vectors (proto/vectors/surface_v1.json) check it bit for bit (Tests/).
//
// FFT layers are evaluated with an FftLayer per layer (FftLayer.cs: from the exported spectrum,
// within 1e-9 m of the server, not bit for bit), given to FromDerived; a surface with an FFT
// layer and no evaluator for it, or with a particle layer, refuses to evaluate (ask the
// server's /sample), and its uniforms carry only what this port computes (see Uniforms).
using System;
using System.Collections.Generic;

namespace Swell
{
    /// <summary>One built wave, as GET /v1/scenes/{id} lists it under derived.layers[].waves.</summary>
    public struct Wave
    {
        /// <summary>Amplitude, m.</summary>
        public double Amplitude;
        /// <summary>Wavenumber k = 2π/λ, rad/m.</summary>
        public double Wavenumber;
        /// <summary>Angular frequency ω, rad/s.</summary>
        public double Omega;
        /// <summary>Unit direction (x, z).</summary>
        public double DirX, DirZ;
        /// <summary>Phase φ, rad (reduced).</summary>
        public double Phase;
        /// <summary>Gerstner steepness Q in [0, 1] (0 for sine waves).</summary>
        public double Steepness;
    }

    /// <summary>Displacement (Dx, y, Dz) at an undisplaced point and its derivatives.</summary>
    public sealed class SurfaceSample
    {
        /// <summary>(Dx, y, Dz), m.</summary>
        public readonly double[] D = new double[3];
        /// <summary>∂D/∂x0.</summary>
        public readonly double[] Dx = new double[3];
        /// <summary>∂D/∂z0.</summary>
        public readonly double[] Dz = new double[3];
    }

    /// <summary>Every field /sample answers at one point.</summary>
    public struct SurfaceQuery
    {
        /// <summary>Height above the world point, m (with inversion).</summary>
        public double Height;
        /// <summary>Unit normal of the displaced surface.</summary>
        public double[] Normal;
        /// <summary>Displacement (Dx, y, Dz) at the point taken as undisplaced, m.</summary>
        public double[] Displacement;
        /// <summary>Jacobian determinant of the horizontal map.</summary>
        public double Jacobian;
        /// <summary>Whether the surface folds here (Jacobian &lt;= 0).</summary>
        public bool Folded;
        /// <summary>Inversion residual, m.</summary>
        public double Residual;
    }

    /// <summary>Inversion settings (query.rs Inversion).</summary>
    public struct Inversion
    {
        /// <summary>Newton (true, the default) or fixed-point steps.</summary>
        public bool Newton;
        /// <summary>Most steps.</summary>
        public int Iterations;
        /// <summary>Stop when the residual is at most this, m.</summary>
        public double Tolerance;
        /// <summary>Newton, 8 steps, 1e-5 m (the server's default).</summary>
        public static readonly Inversion Default = new Inversion { Newton = true, Iterations = 8, Tolerance = 1e-5 };
    }

    /// <summary>The frame's uniform block (GET /v1/scenes/{id}/uniforms).</summary>
    public sealed class FrameUniforms
    {
        /// <summary>Scene time, s.</summary>
        public double T;
        /// <summary>World origin of the frame (x, z), m.</summary>
        public double OriginX, OriginZ;
        /// <summary>Per wave, in f64: wrap(k·(d·o) − ω·t + φ).</summary>
        public double[] Phases;
        /// <summary>The uniform block: phases as f32 padded to 4·max(1, ⌈n/4⌉), then one vec4 per FFT layer.</summary>
        public float[] Block;
        /// <summary>Floats of Block that are phases (the shader's swell_u_phases array, 4 per vec4); the rest is swell_u_fft.</summary>
        public int PhaseSlots;
    }

    /// <summary>The analytic waves of a scene, ready to evaluate.</summary>
    public sealed class Surface
    {
        /// <summary>Standard gravity, m/s² (the model's default).</summary>
        public const double StandardGravity = 9.81;

        sealed class Layer
        {
            public string Kind;
            public Wave[] Waves;
            public double TileSize, Resolution, Choppiness;
            public FftLayer Fft;
            // The factors WaveSoA::new forms, each rounded as the model rounds it.
            public double[] K, Om, Ph, Dxs, Dzs, A, QaDx, QaDz, Ak, Qak;
        }

        readonly List<Layer> layers = new List<Layer>();
        readonly bool horizontal;

        /// <summary>Whether every layer is sine or Gerstner.</summary>
        public bool Analytic { get; private set; }

        /// <summary>Whether Sample, Height and Query evaluate locally: no particle layer, and an FftLayer for every FFT layer.</summary>
        public bool CanSample { get; private set; }

        readonly bool hasFft;

        /// <summary>Whether any layer is a particle layer (its uniforms come from the server).</summary>
        public bool HasParticles { get; private set; }

        Surface(List<Layer> ls)
        {
            if (ls.Count == 0) throw new ArgumentException("a surface needs at least one layer");
            layers = ls;
            Analytic = true;
            CanSample = true;
            foreach (var l in ls)
            {
                if (l.Kind == "fft")
                {
                    Analytic = false;
                    hasFft = true;
                    if (l.Fft == null) CanSample = false;
                    if (l.Choppiness > 0) horizontal = true;
                    continue;
                }
                if (l.Kind == "particles") { Analytic = false; CanSample = false; HasParticles = true; continue; }
                int n = l.Waves.Length;
                l.K = new double[n]; l.Om = new double[n]; l.Ph = new double[n]; l.Dxs = new double[n]; l.Dzs = new double[n];
                l.A = new double[n]; l.QaDx = new double[n]; l.QaDz = new double[n]; l.Ak = new double[n]; l.Qak = new double[n];
                for (int i = 0; i < n; i++)
                {
                    Wave w = l.Waves[i];
                    l.K[i] = w.Wavenumber; l.Om[i] = w.Omega; l.Ph[i] = w.Phase;
                    l.Dxs[i] = w.DirX; l.Dzs[i] = w.DirZ; l.A[i] = w.Amplitude;
                    l.QaDx[i] = w.Steepness * w.Amplitude * w.DirX;
                    l.QaDz[i] = w.Steepness * w.Amplitude * w.DirZ;
                    l.Ak[i] = w.Amplitude * w.Wavenumber;
                    l.Qak[i] = w.Steepness * w.Amplitude * w.Wavenumber;
                    if (l.Kind == "gerstner" && w.Steepness > 0) horizontal = true;
                }
            }
        }

        /// <summary>From layers of built waves: (kind, waves) pairs, "sine" or "gerstner".</summary>
        public static Surface FromWaves(IList<KeyValuePair<string, Wave[]>> layers)
        {
            var ls = new List<Layer>();
            foreach (var kv in layers)
            {
                if (kv.Key != "sine" && kv.Key != "gerstner") throw new ArgumentException("unknown layer kind " + kv.Key);
                ls.Add(new Layer { Kind = kv.Key, Waves = kv.Value });
            }
            return new Surface(ls);
        }

        /// <summary>From a scene's derived block (GET /v1/scenes/{id} → "derived"), every built wave exactly as the server evaluates it.</summary>
        /// <exception cref="FormatException">derived.layers missing or malformed.</exception>
        public static Surface FromDerived(object derived)
        {
            return FromDerived(derived, null);
        }

        /// <summary>
        /// <see cref="FromDerived(object)"/> with an evaluator per FFT layer: <paramref name="fft"/>[i]
        /// for layer i (null for the others), each from that layer's exported spectrum
        /// (<see cref="SwellClient.Spectrum"/>).
        /// </summary>
        /// <exception cref="ArgumentException">An evaluator whose grid is not the layer's.</exception>
        public static Surface FromDerived(object derived, IList<FftLayer> fft)
        {
            var ls = new List<Layer>();
            var list = Json.Get(derived, "layers") as List<object>;
            if (list == null) throw new FormatException("derived.layers is missing: pass scene[\"derived\"] from GET /v1/scenes/{id}");
            foreach (var lo in list)
            {
                string kind = Json.Str(lo, "kind");
                var l = new Layer { Kind = kind };
                if (kind == "sine" || kind == "gerstner")
                {
                    var ws = Json.List(lo, "waves");
                    l.Waves = new Wave[ws.Count];
                    for (int i = 0; i < ws.Count; i++)
                    {
                        var dir = Json.Nums(Json.Get(ws[i], "direction"));
                        l.Waves[i] = new Wave
                        {
                            Amplitude = Json.Num(ws[i], "amplitude"),
                            Wavenumber = Json.Num(ws[i], "wavenumber"),
                            Omega = Json.Num(ws[i], "omega"),
                            DirX = dir[0],
                            DirZ = dir[1],
                            Phase = Json.Num(ws[i], "phase"),
                            Steepness = Json.Num(ws[i], "steepness", 0),
                        };
                    }
                }
                else if (kind == "fft")
                {
                    l.TileSize = Json.Num(lo, "tile_size");
                    l.Resolution = Json.Num(lo, "resolution");
                    l.Choppiness = Json.Num(lo, "choppiness", 0);
                    int at = ls.Count;
                    if (fft != null && at < fft.Count && fft[at] != null)
                    {
                        if (fft[at].Resolution != (int)l.Resolution || fft[at].TileSize != l.TileSize)
                            throw new ArgumentException("the FFT evaluator for layer " + at + " is not that layer's (resolution, tile size)");
                        l.Fft = fft[at];
                    }
                }
                else if (kind != "particles") throw new FormatException("unknown layer kind " + kind);
                ls.Add(l);
            }
            return new Surface(ls);
        }

        /// <summary>
        /// From a surface spec with explicit sine/Gerstner waves in deep water (JSON as parsed by
        /// <see cref="Json.Parse"/>): k = 2π/λ, ω = sqrt(g·k) or c·k, direction normalised, φ
        /// reduced, as Wave::build does. Generators and finite depth need the server's built
        /// waves (<see cref="FromDerived"/>).
        /// </summary>
        public static Surface FromSpec(object spec)
        {
            double g = Json.Num(spec, "gravity", StandardGravity);
            if (Json.Get(spec, "depth") != null) throw new ArgumentException("finite depth needs tanh from the model: build from scene.derived");
            var ls = new List<Layer>();
            foreach (var lo in Json.List(spec, "layers"))
            {
                string kind = Json.Str(lo, "kind");
                if (kind != "sine" && kind != "gerstner") throw new ArgumentException(kind + " layers cannot be built locally: use scene.derived");
                if (Json.Get(lo, "cascade") != null || Json.Get(lo, "spectrum") != null)
                    throw new ArgumentException("generated waves (cascade, spectrum) come from scene.derived");
                var ws = Json.List(lo, "waves");
                var waves = new Wave[ws.Count];
                for (int i = 0; i < ws.Count; i++) waves[i] = BuildWave(ws[i], kind == "gerstner" ? Json.Num(ws[i], "steepness", 0) : 0, g);
                ls.Add(new Layer { Kind = kind, Waves = waves });
            }
            return new Surface(ls);
        }

        static Wave BuildWave(object w, double steepness, double g)
        {
            double amplitude = Json.Num(w, "amplitude");
            double wavelength = Json.Num(w, "wavelength");
            double phase = Json.Num(w, "phase", 0);
            if (!(amplitude >= 0) || !(wavelength > 0) || !(steepness >= 0 && steepness <= 1))
                throw new ArgumentException("a wave needs amplitude >= 0, wavelength > 0, steepness in [0, 1]");
            var d = Json.Nums(Json.Get(w, "direction"));
            double x = d[0], z = d[1];
            double len = Math.Sqrt(x * x + z * z);
            double dx, dz;
            if (len > 0 && !double.IsInfinity(len)) { dx = x / len; dz = z / len; }
            else if (len > 0)
            {
                double m = Math.Max(Math.Abs(x), Math.Abs(z));
                double ux = x / m, uz = z / m;
                len = Math.Sqrt(ux * ux + uz * uz);
                dx = ux / len; dz = uz / len;
            }
            else throw new ArgumentException("direction must not be zero");
            double k = SwellMath.Tau / wavelength;
            object speed = Json.Get(w, "speed");
            double omega;
            if (speed is double) omega = (double)speed * k;
            else omega = Math.Sqrt(g * k);
            return new Wave { Amplitude = amplitude, Wavenumber = k, Omega = omega, DirX = dx, DirZ = dz, Phase = SwellMath.ReducePhase(phase), Steepness = steepness };
        }

        /// <summary>
        /// Sum of every layer's displacement at the undisplaced point (x0, z0), time t, and its
        /// derivatives when asked (surface.rs sample_lanes).
        /// </summary>
        /// <exception cref="NotSupportedException">The surface has a particle layer, or an FFT layer without an evaluator.</exception>
        public SurfaceSample Sample(double x0, double z0, double t, bool derivatives)
        {
            return Sample(x0, z0, t, derivatives ? FftRead.Derivatives : FftRead.Displacement);
        }

        /// <summary>
        /// <see cref="Sample(double, double, double, bool)"/> reading FFT layers as
        /// <paramref name="read"/> says (<see cref="FftRead.Newton"/>: an inversion round's
        /// Jacobian, from the displacement interpolant); sine and Gerstner layers give their
        /// derivatives for any read but <see cref="FftRead.Displacement"/>.
        /// </summary>
        public SurfaceSample Sample(double x0, double z0, double t, FftRead read)
        {
            if (!CanSample)
                throw new NotSupportedException(HasParticles
                    ? "particle layers are not evaluated locally by this client: ask the server's /sample"
                    : "this surface has an FFT layer and no FftLayer for it: build it with FromDerived(derived, fft)");
            bool derivatives = read != FftRead.Displacement;
            var o = new SurfaceSample();
            double[] d = o.D, ddx = o.Dx, ddz = o.Dz;
            foreach (var L in layers)
            {
                if (L.Fft != null)
                {
                    L.Fft.Sample(x0, z0, t, read, o);
                    continue;
                }
                int n = L.Waves.Length;
                for (int w = 0; w < n; w++)
                {
                    double wt = L.Om[w] * t;
                    double dxw = L.Dxs[w];
                    double dzw = L.Dzs[w];
                    double along = dxw * x0 + dzw * z0;
                    double ph = L.K[w] * along;
                    ph = ph - wt;
                    ph = ph + L.Ph[w];
                    double s, c;
                    SwellMath.SinCos(SwellMath.ReducePhase(ph), out s, out c);
                    d[0] += L.QaDx[w] * c;
                    d[1] += L.A[w] * s;
                    d[2] += L.QaDz[w] * c;
                    if (derivatives)
                    {
                        double akc = L.Ak[w] * c;
                        double qaks = L.Qak[w] * s;
                        ddx[0] -= qaks * dxw * dxw;
                        ddx[1] += akc * dxw;
                        ddx[2] -= qaks * dxw * dzw;
                        ddz[0] -= qaks * dxw * dzw;
                        ddz[1] += akc * dzw;
                        ddz[2] -= qaks * dzw * dzw;
                    }
                }
            }
            return o;
        }

        /// <summary>The best iterate of solving p0 + D(p0, t) = (x, z) (query.rs invert_lanes).</summary>
        public SurfaceSample Invert(double x, double z, double t, bool derivatives, Inversion inv, out double residual)
        {
            if (!horizontal)
            {
                residual = 0;
                return Sample(x, z, t, derivatives);
            }
            // What a round reads (query.rs invert_lanes_v): Newton's Jacobian (an FFT layer's from
            // its displacement grids' interpolant); the Jacobian and slope grids of an FFT layer
            // only in one more evaluation at the point kept, for a caller that wants derivatives.
            FftRead rounds = inv.Newton ? FftRead.Newton
                : derivatives && !hasFft ? FftRead.Derivatives : FftRead.Displacement;
            double px = x, pz = z;
            SurfaceSample best = null;
            double bestR = 0, bestX = x, bestZ = z;
            for (int it = 0; ; it++)
            {
                var s = Sample(px, pz, t, rounds);
                double fx = (px + s.D[0]) - x;
                double fz = (pz + s.D[2]) - z;
                double r = Math.Sqrt(fx * fx + fz * fz);
                if (best == null || r < bestR) { best = s; bestR = r; bestX = px; bestZ = pz; }
                if (r <= inv.Tolerance || it >= inv.Iterations || double.IsNaN(r) || double.IsInfinity(r)) break;
                double sx = fx, sz = fz;
                if (inv.Newton)
                {
                    double a = 1.0 + s.Dx[0];
                    double b = s.Dz[0];
                    double c = s.Dx[2];
                    double dd = 1.0 + s.Dz[2];
                    double det = a * dd - b * c;
                    if (det > 1e-9)
                    {
                        sx = (dd * fx - b * fz) / det;
                        sz = (a * fz - c * fx) / det;
                    }
                }
                px -= sx;
                pz -= sz;
            }
            if (derivatives && hasFft) best = Sample(bestX, bestZ, t, FftRead.Derivatives);
            residual = bestR;
            return best;
        }

        /// <summary>Height of the surface above world (x, z) at t, m (with inversion).</summary>
        public double Height(double x, double z, double t)
        {
            double r;
            return Invert(x, z, t, false, Inversion.Default, out r).D[1];
        }

        /// <summary>Every field /sample answers at world (x, z), time t, as the server computes it.</summary>
        public SurfaceQuery Query(double x, double z, double t)
        {
            return Query(x, z, t, Inversion.Default);
        }

        /// <summary>As <see cref="Query(double,double,double)"/> with another inversion.</summary>
        public SurfaceQuery Query(double x, double z, double t, Inversion inversion)
        {
            double residual;
            var s = Invert(x, z, t, true, inversion, out residual);
            var q = new SurfaceQuery
            {
                Height = s.D[1],
                Normal = NormalOf(s),
                Jacobian = JacobianOf(s),
                Residual = residual,
                Displacement = (double[])Sample(x, z, t, false).D.Clone(),
            };
            q.Folded = q.Jacobian <= 0.0;
            return q;
        }

        /// <summary>Unit normal of the displaced surface (SurfaceSample::normal), straight up at a fold's edge.</summary>
        public static double[] NormalOf(SurfaceSample s)
        {
            // (e_x + dx) and (e_z + dz); `0 + v` as glam adds the unit vector (it turns -0 into +0).
            double tx0 = 1.0 + s.Dx[0], tx1 = 0.0 + s.Dx[1], tx2 = 0.0 + s.Dx[2];
            double tz0 = 0.0 + s.Dz[0], tz1 = 0.0 + s.Dz[1], tz2 = 1.0 + s.Dz[2];
            double nx = tz1 * tx2 - tx1 * tz2;
            double ny = tz2 * tx0 - tx2 * tz0;
            double nz = tz0 * tx1 - tx0 * tz1;
            double len = Math.Sqrt(nx * nx + ny * ny + nz * nz);
            if (len > 1e-300 && !double.IsInfinity(len)) return new[] { nx / len, ny / len, nz / len };
            return new[] { 0.0, 1.0, 0.0 };
        }

        /// <summary>Jacobian determinant of p0 ↦ p0 + (Dx, Dz).</summary>
        public static double JacobianOf(SurfaceSample s)
        {
            return (1.0 + s.Dx[0]) * (1.0 + s.Dz[2]) - s.Dz[0] * s.Dx[2];
        }

        /// <summary>
        /// The frame's uniforms in double precision (crates/swell-shaders/src/uniforms.rs, GET
        /// …/uniforms): phases[i] = wrap(k_i·(d_i·o) − ω_i·t + φ_i) for every sine and Gerstner
        /// wave, the block of those as f32 padded to 4·max(1, ⌈n/4⌉), then one vec4 per FFT
        /// layer (the origin's grid coordinate on its tile).
        /// </summary>
        /// <exception cref="NotSupportedException">A particle layer: its block members come from GET …/uniforms.</exception>
        public FrameUniforms Uniforms(double t, double ox, double oz)
        {
            if (HasParticles) throw new NotSupportedException("particle layers' uniforms are not computed by this client: use GET /v1/scenes/{id}/uniforms");
            if (double.IsNaN(t) || double.IsInfinity(t)) throw new ArgumentException("t must be finite");
            var phases = new List<double>();
            int ffts = 0;
            foreach (var L in layers)
            {
                if (L.Kind == "fft") { ffts++; continue; }
                for (int w = 0; w < L.Waves.Length; w++)
                {
                    double along = L.Dxs[w] * ox + L.Dzs[w] * oz;
                    double ph = L.K[w] * along;
                    ph = ph - L.Om[w] * t;
                    ph = ph + L.Ph[w];
                    phases.Add(SwellMath.ReducePhase(ph));
                }
            }
            int waves = 4 * Math.Max(1, (phases.Count + 3) / 4);
            var block = new float[waves + 4 * ffts];
            for (int i = 0; i < phases.Count; i++) block[i] = (float)phases[i];
            int f = 0;
            foreach (var L in layers)
            {
                if (L.Kind != "fft") continue;
                block[waves + 4 * f] = (float)Grid(ox, L.TileSize, L.Resolution);
                block[waves + 4 * f + 1] = (float)Grid(oz, L.TileSize, L.Resolution);
                f++;
            }
            return new FrameUniforms { T = t, OriginX = ox, OriginZ = oz, Phases = phases.ToArray(), Block = block, PhaseSlots = waves };
        }

        // (o mod L)·N/L (Rust's rem_euclid, then ·N/L, in that order).
        static double Grid(double x, double l, double n)
        {
            double r = x % l;
            if (r < 0) r += l;
            double v = (r * n) / l;
            return v >= n ? 0 : v;
        }
    }
}
