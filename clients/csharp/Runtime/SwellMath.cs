// Deterministic maths, ported operation for operation from crates/swell-waves/src/math
// (phase.rs, trig.rs) by way of clients/js/src/math.js. C# doubles are IEEE-754 binary64 and
// `*`, `+`, `-`, `/` and Math.Sqrt are correctly rounded, so the same operations in the same
// order give the model's bits — as long as the compiler keeps them apart: see README.md
// ("What Mono proves") about IL2CPP/clang contracting a*b+c into a fused multiply-add.
// Math.Sin/Math.Cos are not specified to the bit and are never used for model values.
using System;
using System.Globalization;

namespace Swell
{
    /// <summary>The model's deterministic phase reduction and sin/cos kernels.</summary>
    public static class SwellMath
    {
        /// <summary>2π.</summary>
        public const double Tau = 6.283185307179586;
        const double InvTau = 0.15915494309189535;
        // 2π = Tau1 + Tau2 + Tau3 + Tau4: Cody–Waite pieces of 21 significant bits (phase.rs).
        const double Tau1 = 6.283184051513672;
        const double Tau2 = 1.2556656656670384e-6;
        const double Tau3 = 2.489347703665823e-13;
        const double Tau4 = 1.1650928224373424e-19;
        const double Two52 = 4503599627370496.0;

        const double PiO2_1 = 1.5707963267341256;
        const double PiO2_2 = 6.077100506506192e-11;
        const double TwoOverPi = 0.6366197723675814;
        // fdlibm __kernel_sin / __kernel_cos coefficients (trig.rs).
        const double S1 = -1.66666666666666324348e-1;
        const double S2 = 8.33333333332248946124e-3;
        const double S3 = -1.98412698298579493134e-4;
        const double S4 = 2.75573137070700676789e-6;
        const double S5 = -2.50507602534068634195e-8;
        const double S6 = 1.58969099521155010221e-10;
        const double C1 = 4.16666666666666019037e-2;
        const double C2 = -1.38888888888741095749e-3;
        const double C3 = 2.48015872894767294178e-5;
        const double C4 = -2.75573143513906633035e-7;
        const double C5 = 2.08757232129817482790e-9;
        const double C6 = -1.13596475577881948265e-11;

        /// <summary>Whether the sign bit of x is set (true for -0).</summary>
        public static bool SignBit(double x)
        {
            return BitConverter.DoubleToInt64Bits(x) < 0;
        }

        /// <summary>|v| with the sign of s (Rust's f64::copysign).</summary>
        public static double CopySign(double v, double s)
        {
            long bits = BitConverter.DoubleToInt64Bits(v) & 0x7fffffffffffffffL;
            if (SignBit(s)) bits |= long.MinValue;
            return BitConverter.Int64BitsToDouble(bits);
        }

        /// <summary>Nearest integer, ties away from zero, sign kept (phase.rs round_ties_away).</summary>
        public static double RoundTiesAway(double x)
        {
            double c = CopySign(Two52, x);
            double r = (x + c) - c;
            double d = x - r;
            double half = CopySign(0.5, x);
            if (d == half) r = r + 2.0 * half;
            if (Math.Abs(x) >= Two52) r = x;
            return CopySign(r, x);
        }

        /// <summary>
        /// Reduces a phase (rad) to [−π, π]: x − 2π·round(x/2π) with 2π in four pieces, exact for
        /// |x| &lt; 2.7·10¹⁰ rad (phase.rs reduce_phase).
        /// </summary>
        public static double ReducePhase(double x)
        {
            double n = RoundTiesAway(x * InvTau);
            double a = x - n * Tau1;
            double b = a - n * Tau2;
            double c = b - n * Tau3;
            return c - n * Tau4;
        }

        static double KernelSin(double y)
        {
            double z = y * y;
            double r = S2 + z * (S3 + z * (S4 + z * (S5 + z * S6)));
            return y + y * z * (S1 + z * r);
        }

        static double KernelCos(double y)
        {
            double z = y * y;
            double r = z * (C1 + z * (C2 + z * (C3 + z * (C4 + z * (C5 + z * C6)))));
            double hz = 0.5 * z;
            double w = 1.0 - hz;
            return w + (((1.0 - w) - hz) + z * r);
        }

        /// <summary>sin x and cos x for finite x (rad), the model's kernel to the bit (trig.rs sin_cos).</summary>
        public static void SinCos(double x, out double sin, out double cos)
        {
            double r = ReducePhase(x);
            double q = RoundTiesAway(r * TwoOverPi);
            double y = (r - q * PiO2_1) - q * PiO2_2;
            double s = KernelSin(y);
            double c = KernelCos(y);
            bool odd = Math.Abs(q) == 1.0;
            double a = odd ? c : s;
            double b = odd ? s : c;
            bool negSin = q == 2.0 || q < -0.5;
            bool negCos = q > 0.5 || q == -2.0;
            sin = negSin ? -a : a;
            cos = negCos ? -b : b;
        }

        /// <summary>The hex of a double's IEEE-754 bits, big-endian (as proto/vectors writes them).</summary>
        public static string BitsHex(double x)
        {
            return BitConverter.DoubleToInt64Bits(x).ToString("x16", CultureInfo.InvariantCulture);
        }

        /// <summary>The double whose IEEE-754 bits are the 16 hex digits.</summary>
        public static double FromBitsHex(string hex)
        {
            return BitConverter.Int64BitsToDouble(long.Parse(hex, NumberStyles.HexNumber, CultureInfo.InvariantCulture));
        }
    }
}
