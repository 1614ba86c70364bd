// FFT layers on the CPU from the exported spectrum (GET …/spectrum?layer=N, `swell-spectrum/1`):
// a port of clients/js/src/fft.js, so a managed client (a Unity WebGL build, a platform without
// the native option) evaluates `open-sea` and `storm` too.
//
// Per frame time t: t_r = t mod T; h̃(k) = h0(k)·e^{−iω t_r} + conj(h0(−k))·e^{+iω t_r}; inverse
// 2-D FFTs (radix 2, unnormalised) give the grids the model keeps: height h, displacement Dx, Dz
// (D = Σ i·λ·(k/|k|)·h̃·e^{ik·x}), slopes ∂h/∂x, ∂h/∂z and the Jacobian terms ∂Dx/∂x, ∂Dz/∂z,
// ∂Dx/∂z; two real grids share one complex transform (h̃ is Hermitian, so each field is real).
// The layer is read as the server reads it by default: frames at grid times n·time_step, linear
// in time between the two around t, Catmull–Rom (bicubic) in space, Newton's Jacobian from the
// derivatives of that interpolant (model version 3). Not bit for bit: the butterflies differ
// from the server's, so results differ by the FFT's rounding (~1e-15 m on open-sea, ~1e-14 m on
// storm; the tests hold them within 1e-9 m of the server).
using System;
using System.Collections.Generic;
using System.Text;

namespace Swell
{
    /// <summary>A parsed `swell-spectrum/1` export: h0(k) and ω(k) of every mode.</summary>
    public sealed class FftSpectrum
    {
        /// <summary>The export's JSON header (tile_size, repeat_period, choppiness, time_step, grid_steps, resolution, …).</summary>
        public object Header;
        /// <summary>Grid resolution N (a power of two).</summary>
        public int N;
        /// <summary>Per mode (row j, column i, index j·N + i): Re h0, Im h0, ω (rad/s).</summary>
        public double[] Records;

        /// <summary>Parses the bytes of GET …/spectrum?layer=N.</summary>
        /// <exception cref="FormatException">Not a swell-spectrum/1 export, or truncated.</exception>
        public static FftSpectrum Parse(byte[] bytes)
        {
            if (bytes == null || bytes.Length < 8 || Encoding.ASCII.GetString(bytes, 0, 4) != "SWSP")
                throw new FormatException("not a swell-spectrum export (magic)");
            int hlen = (int)BitConverter.ToUInt32(bytes, 4);
            if (hlen < 0 || 8 + hlen > bytes.Length) throw new FormatException("spectrum header runs past the end");
            object header = Json.Parse(Encoding.UTF8.GetString(bytes, 8, hlen));
            if (Json.Str(header, "format") != "swell-spectrum/1") throw new FormatException("unknown spectrum format " + Json.Str(header, "format"));
            int n = (int)Json.Num(header, "resolution");
            if (n < 2 || (n & (n - 1)) != 0) throw new FormatException("spectrum resolution must be a power of two");
            int offset = (int)Json.Num(header, "data_offset");
            int count = n * n * 3;
            if (offset < 8 + hlen || offset + 8L * count > bytes.Length) throw new FormatException("spectrum data runs past the end");
            if (!BitConverter.IsLittleEndian) throw new NotSupportedException("a big-endian machine");
            var records = new double[count];
            Buffer.BlockCopy(bytes, offset, records, 0, 8 * count);
            return new FftSpectrum { Header = header, N = n, Records = records };
        }
    }

    /// <summary>What an FFT layer's read gives (fft.js `sample`'s `derivatives`).</summary>
    public enum FftRead
    {
        /// <summary>The displacement alone.</summary>
        Displacement,
        /// <summary>With the Jacobian and slope grids (normals, Jacobian).</summary>
        Derivatives,
        /// <summary>An inversion round: Newton's Jacobian from the displacement interpolant, no slopes.</summary>
        Newton,
    }

    /// <summary>One frame's grids, each N·N, row-major (index j·N + i).</summary>
    public sealed class FftFrame
    {
        /// <summary>Scene time of the frame, s.</summary>
        public double T;
        /// <summary>h, Dx, Dz, ∂h/∂x, ∂h/∂z, ∂Dx/∂x, ∂Dz/∂z, ∂Dx/∂z, in that order.</summary>
        public double[][] Grids = new double[8][];
        /// <summary>Height, m.</summary>
        public double[] H { get { return Grids[0]; } }
        /// <summary>Horizontal displacement along x, m.</summary>
        public double[] Dx { get { return Grids[1]; } }
        /// <summary>Horizontal displacement along z, m.</summary>
        public double[] Dz { get { return Grids[2]; } }
    }

    /// <summary>
    /// One FFT layer, evaluated on the CPU: <c>new FftLayer(FftSpectrum.Parse(bytes))</c>;
    /// <see cref="Frame"/> gives the grids at t, <see cref="Sample"/> reads the layer at an
    /// undisplaced point as the server does. Not thread-safe (a small cache of frames).
    /// </summary>
    public sealed class FftLayer
    {
        const int H = 0, DX = 1, DZ = 2, SX = 3, SZ = 4, JXX = 5, JZZ = 6, JXZ = 7;

        readonly int n;
        readonly double tile, period, lambda, timeStep;
        readonly int gridSteps;
        readonly double[] records, tw, kx, kz, kl;
        readonly int cacheFrames;
        readonly Dictionary<double, FftFrame> cache = new Dictionary<double, FftFrame>();
        readonly Queue<double> order = new Queue<double>();
        // A read's working values, reused (the class is not thread-safe anyway): a probe's
        // Newton rounds read the layer several times, and a game's GC should not see them.
        readonly int[] cols = new int[4];
        readonly double[] wx = new double[4], wz = new double[4], dwx = new double[4], dwz = new double[4];
        readonly double[] va = new double[8], vb = new double[8];

        /// <summary>The layer of a parsed spectrum; keeps the last <paramref name="cacheFrames"/> frames.</summary>
        public FftLayer(FftSpectrum spectrum, int cacheFrames = 4)
        {
            n = spectrum.N;
            tile = Json.Num(spectrum.Header, "tile_size");
            period = Json.Num(spectrum.Header, "repeat_period");
            lambda = Json.Num(spectrum.Header, "choppiness");
            timeStep = Json.Num(spectrum.Header, "time_step");
            gridSteps = (int)Json.Num(spectrum.Header, "grid_steps");
            if (!(tile > 0) || !(period > 0) || !(timeStep > 0) || gridSteps < 1)
                throw new FormatException("spectrum header: tile_size, repeat_period, time_step must be > 0 and grid_steps >= 1");
            records = spectrum.Records;
            tw = Twiddles(n);
            this.cacheFrames = Math.Max(2, cacheFrames);
            double dk = SwellMath.Tau / tile;
            int h = n / 2;
            kx = new double[n * n]; kz = new double[n * n]; kl = new double[n * n];
            for (int j = 0; j < n; j++)
                for (int i = 0; i < n; i++)
                {
                    int r = j * n + i;
                    kx[r] = (i - h) * dk; kz[r] = (j - h) * dk;
                    kl[r] = Math.Sqrt(kx[r] * kx[r] + kz[r] * kz[r]);
                }
        }

        /// <summary>Grid resolution N.</summary>
        public int Resolution { get { return n; } }
        /// <summary>Tile size L, m.</summary>
        public double TileSize { get { return tile; } }

        /// <summary>Twiddles e^{+2πik/n}, k &lt; n/2, interleaved (cos, sin), with the model's sin/cos.</summary>
        static double[] Twiddles(int n)
        {
            var t = new double[n];
            for (int k = 0; k < n / 2; k++)
            {
                double s, c;
                SwellMath.SinCos(SwellMath.Tau * k / n, out s, out c);
                t[2 * k] = c; t[2 * k + 1] = s;
            }
            return t;
        }

        /// <summary>In-place radix-2 complex FFT with e^{+i…} (an unnormalised inverse DFT) of n entries at off, off + stride, ….</summary>
        static void InverseFft1(double[] re, double[] im, int n, int off, int stride, double[] tw)
        {
            for (int i = 1, j = 0; i < n; i++)
            {
                int bit = n >> 1;
                for (; (j & bit) != 0; bit >>= 1) j ^= bit;
                j ^= bit;
                if (i < j)
                {
                    int a = off + i * stride, b = off + j * stride;
                    double t = re[a]; re[a] = re[b]; re[b] = t;
                    t = im[a]; im[a] = im[b]; im[b] = t;
                }
            }
            for (int len = 2; len <= n; len <<= 1)
            {
                int half = len >> 1;
                int step = n / len;
                for (int i = 0; i < n; i += len)
                    for (int k = 0; k < half; k++)
                    {
                        double wr = tw[2 * k * step], wi = tw[2 * k * step + 1];
                        int a = off + (i + k) * stride, b = off + (i + k + half) * stride;
                        double xr = re[b] * wr - im[b] * wi;
                        double xi = re[b] * wi + im[b] * wr;
                        re[b] = re[a] - xr; im[b] = im[a] - xi;
                        re[a] += xr; im[a] += xi;
                    }
            }
        }

        /// <summary>2-D inverse FFT (e^{+i…}, unnormalised) of an n×n complex grid, row-major (index j·n + i), in place.</summary>
        public static void InverseFft2(double[] re, double[] im, int n)
        {
            if (n < 1 || (n & (n - 1)) != 0 || re.Length < n * n || im.Length < n * n)
                throw new ArgumentException("an n×n grid with n a power of two");
            var tw = Twiddles(n);
            InverseFft2(re, im, n, tw);
        }

        static void InverseFft2(double[] re, double[] im, int n, double[] tw)
        {
            for (int j = 0; j < n; j++) InverseFft1(re, im, n, j * n, 1, tw);
            // Columns through a contiguous line: strided butterflies thrash the cache.
            var cr = new double[n];
            var ci = new double[n];
            for (int i = 0; i < n; i++)
            {
                for (int j = 0; j < n; j++) { cr[j] = re[j * n + i]; ci[j] = im[j * n + i]; }
                InverseFft1(cr, ci, n, 0, 1, tw);
                for (int j = 0; j < n; j++) { re[j * n + i] = cr[j]; im[j * n + i] = ci[j]; }
            }
        }

        /// <summary>The grids at exactly t (no time grid).</summary>
        public FftFrame Frame(double t)
        {
            FftFrame hit;
            if (cache.TryGetValue(t, out hit)) return hit;
            double tr = t % period;
            if (tr < 0) tr += period;
            int n2 = n * n;
            // Four complex transforms, two real fields each: (h, sx), (sz, dx), (dz, jxx), (jzz, jxz).
            var b = new double[8][];
            for (int q = 0; q < 8; q++) b[q] = new double[n2];
            double[] b0r = b[0], b0i = b[1], b1r = b[2], b1i = b[3], b2r = b[4], b2i = b[5], b3r = b[6], b3i = b[7];
            for (int j = 0; j < n; j++)
            {
                int jm = (n - j) & (n - 1);
                for (int i = 0; i < n; i++)
                {
                    int r = j * n + i;
                    int im_ = (n - i) & (n - 1);
                    int rm = jm * n + im_;
                    double s, c;
                    SwellMath.SinCos(records[3 * r + 2] * tr, out s, out c);
                    double ar = records[3 * r], ai = records[3 * r + 1];
                    double br = records[3 * rm], bi = -records[3 * rm + 1];
                    // h0(k)·e^{−iωt} + conj(h0(−k))·e^{+iωt}
                    double hr = (ar * c + ai * s) + (br * c - bi * s);
                    double hi = (ai * c - ar * s) + (bi * c + br * s);
                    if (hr == 0 && hi == 0) continue;
                    double k = kl[r];
                    double kxr = kx[r], kzr = kz[r];
                    double ux = k > 0 ? kxr / k : 0, uz = k > 0 ? kzr / k : 0;
                    // Field spectra c·h̃: 1 (h), i·kx (sx), i·kz (sz), i·λ·ux (dx), i·λ·uz (dz),
                    // −λ·kx·ux (jxx), −λ·kz·uz (jzz), −λ·kx·uz (jxz); A + i·B packed as
                    // re = A.re − B.im, im = A.im + B.re.
                    double sxr = -kxr * hi, sxi = kxr * hr;
                    double szr = -kzr * hi, szi = kzr * hr;
                    double dxr = -lambda * ux * hi, dxi = lambda * ux * hr;
                    double dzr = -lambda * uz * hi, dzi = lambda * uz * hr;
                    double cxx = -lambda * kxr * ux, czz = -lambda * kzr * uz, cxz = -lambda * kxr * uz;
                    b0r[r] = hr - sxi; b0i[r] = hi + sxr;
                    b1r[r] = szr - dxi; b1i[r] = szi + dxr;
                    b2r[r] = dzr - cxx * hi; b2i[r] = dzi + cxx * hr;
                    b3r[r] = czz * hr - cxz * hi; b3i[r] = czz * hi + cxz * hr;
                }
            }
            var f = new FftFrame { T = t };
            int[,] pairs = { { H, SX }, { SZ, DX }, { DZ, JXX }, { JZZ, JXZ } };
            for (int p = 0; p < 4; p++)
            {
                double[] re = b[2 * p], im = b[2 * p + 1];
                InverseFft2(re, im, n, tw);
                // Mode index i − N/2: node (p, q) picks up (−1)^(p+q).
                for (int j = 0; j < n; j++)
                    for (int i = 0; i < n; i++)
                        if (((i + j) & 1) != 0) { int r = j * n + i; re[r] = -re[r]; im[r] = -im[r]; }
                f.Grids[pairs[p, 0]] = re;
                f.Grids[pairs[p, 1]] = im;
            }
            if (cache.Count >= cacheFrames) cache.Remove(order.Dequeue());
            cache[t] = f;
            order.Enqueue(t);
            return f;
        }

        /// <summary>The grid frames around t and the weight of the later one (FftLayer::grid_position).</summary>
        void GridPosition(double t, out double time, out double nextTime, out double weight)
        {
            double tr = t % period;
            if (tr < 0) tr += period;
            int m = gridSteps;
            int index = (int)Math.Min(Math.Floor(tr / timeStep), m - 1);
            if (index + 1 < m && GridTime(index + 1) <= tr) index += 1;
            else if (index > 0 && GridTime(index) > tr) index -= 1;
            weight = Math.Min(Math.Max((tr - GridTime(index)) / timeStep, 0), 1);
            int next = index + 1 == m ? 0 : index + 1;
            time = GridTime(index);
            nextTime = GridTime(next);
        }

        double GridTime(int i) { return (i % gridSteps) * timeStep; }

        /// <summary>Grid coordinate of x (sample.rs grid_coord): node and fraction.</summary>
        void Coord(double x, out int node, out double frac)
        {
            double u = Math.Abs(x) < tile ? (x < 0 ? x + tile : x) : ((x % tile) + tile) % tile;
            double g = u * n / tile;
            double t = Math.Floor(g);
            node = (int)t & (n - 1);
            frac = (g - t) + 0.0;
        }

        static void CatmullRom(double t, double[] w)
        {
            w[0] = 0.5 * (((-t + 2.0) * t - 1.0) * t);
            w[1] = 0.5 * ((3.0 * t - 5.0) * t * t + 2.0);
            w[2] = 0.5 * (((-3.0 * t + 4.0) * t + 1.0) * t);
            w[3] = 0.5 * ((t - 1.0) * t * t);
        }

        static void CatmullRomSlope(double t, double[] w)
        {
            w[0] = 0.5 * ((-3.0 * t + 4.0) * t - 1.0);
            w[1] = 0.5 * ((9.0 * t - 10.0) * t);
            w[2] = 0.5 * ((-9.0 * t + 8.0) * t + 1.0);
            w[3] = 0.5 * ((3.0 * t - 2.0) * t);
        }

        /// <summary>Bicubic read of the 8 grids of f at (x0, z0), and with Newton, the Jacobian of the displacement interpolant in v[JXX], v[JZZ], v[JXZ] and 0 slopes.</summary>
        void Read(FftFrame f, double x0, double z0, bool newton, double[] v)
        {
            int i, j;
            double fx, fz;
            Coord(x0, out i, out fx);
            Coord(z0, out j, out fz);
            int m = n - 1;
            cols[0] = (i - 1) & m; cols[1] = i; cols[2] = (i + 1) & m; cols[3] = (i + 2) & m;
            CatmullRom(fx, wx);
            CatmullRom(fz, wz);
            for (int q = 0; q < 8; q++)
            {
                double[] g = f.Grids[q];
                double acc = 0;
                for (int bb = 0; bb < 4; bb++)
                {
                    int row = ((j + bb - 1) & m) * n;
                    double r = 0;
                    for (int a = 0; a < 4; a++) r += wx[a] * g[row + cols[a]];
                    acc += wz[bb] * r;
                }
                v[q] = acc;
            }
            if (!newton) return;
            CatmullRomSlope(fx, dwx);
            CatmullRomSlope(fz, dwz);
            double xx, xz, zx, zz;
            Gradient(f.Grids[DX], j, m, out xx, out xz);
            Gradient(f.Grids[DZ], j, m, out zx, out zz);
            double s = n / tile;
            v[JXX] = xx * s;
            v[JZZ] = zz * s;
            v[JXZ] = 0.5 * (xz * s + zx * s);
            v[SX] = 0;
            v[SZ] = 0;
        }

        /// <summary>The Catmull–Rom interpolant's gradient of grid g at the stencil Read set up (per node step).</summary>
        void Gradient(double[] g, int j, int m, out double gx, out double gz)
        {
            gx = 0; gz = 0;
            for (int bb = 0; bb < 4; bb++)
            {
                int row = ((j + bb - 1) & m) * n;
                double rv = 0, rd = 0;
                for (int a = 0; a < 4; a++)
                {
                    double x = g[row + cols[a]];
                    rv += wx[a] * x;
                    rd += dwx[a] * x;
                }
                gx += wz[bb] * rd;
                gz += dwz[bb] * rv;
            }
        }

        /// <summary>
        /// Adds the layer at undisplaced (x0, z0), time t, to <paramref name="into"/>: its
        /// displacement, and its derivatives unless <paramref name="read"/> is
        /// <see cref="FftRead.Displacement"/> (fft.js FftLayer.sample).
        /// </summary>
        /// <exception cref="ArgumentException">t is not finite (a point that is not gives NaN, as the analytic layers do).</exception>
        public void Sample(double x0, double z0, double t, FftRead read, SurfaceSample into)
        {
            if (double.IsNaN(t) || double.IsInfinity(t)) throw new ArgumentException("t must be finite", "t");
            double time, nextTime, w;
            GridPosition(t, out time, out nextTime, out w);
            bool newton = read == FftRead.Newton;
            double[] v = va, b = vb;
            Read(Frame(time), x0, z0, newton, v);
            if (w > 0)
            {
                Read(Frame(nextTime), x0, z0, newton, b);
                for (int q = 0; q < 8; q++) v[q] = v[q] + (b[q] - v[q]) * w;
            }
            into.D[0] += v[DX]; into.D[1] += v[H]; into.D[2] += v[DZ];
            if (read == FftRead.Displacement) return;
            into.Dx[0] += v[JXX]; into.Dx[1] += v[SX]; into.Dx[2] += v[JXZ];
            into.Dz[0] += v[JXZ]; into.Dz[1] += v[SZ]; into.Dz[2] += v[JZZ];
        }
    }
}
