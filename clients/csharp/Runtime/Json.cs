// A minimal JSON reader and writer for the wire's own messages (no dependency beyond the base
// class library: Unity and .NET Standard 2.1 have no System.Text.Json).
//
// Values are plain objects: Dictionary<string, object> (keys in document order), List<object>,
// string, double, bool, null. Numbers are read to the nearest double, ties to even
// (ParseDouble: the runtime's double.Parse, then corrected against the decimal's exact value;
// Mono's double.Parse reads about one in 3,600 shortest-form decimals one ulp off), so a number
// the server wrote with its shortest round-trip form reads back to the server's bits; numbers are
// written with the "R" format, checked to round-trip.
using System;
using System.Collections.Generic;
using System.Globalization;
using System.Numerics;
using System.Text;

namespace Swell
{
    /// <summary>Parses and writes JSON as plain objects.</summary>
    public static class Json
    {
        /// <summary>Parses one JSON value.</summary>
        /// <exception cref="FormatException">The text is not JSON.</exception>
        public static object Parse(string text)
        {
            int i = 0;
            object v = ReadValue(text, ref i);
            SkipWs(text, ref i);
            if (i != text.Length) throw new FormatException("trailing characters at " + i);
            return v;
        }

        static void SkipWs(string s, ref int i)
        {
            while (i < s.Length && (s[i] == ' ' || s[i] == '\t' || s[i] == '\n' || s[i] == '\r')) i++;
        }

        static object ReadValue(string s, ref int i)
        {
            SkipWs(s, ref i);
            if (i >= s.Length) throw new FormatException("unexpected end of JSON");
            char c = s[i];
            if (c == '{')
            {
                var d = new Dictionary<string, object>();
                i++;
                SkipWs(s, ref i);
                if (i < s.Length && s[i] == '}') { i++; return d; }
                while (true)
                {
                    SkipWs(s, ref i);
                    string k = ReadString(s, ref i);
                    SkipWs(s, ref i);
                    Expect(s, ref i, ':');
                    d[k] = ReadValue(s, ref i);
                    SkipWs(s, ref i);
                    if (i < s.Length && s[i] == ',') { i++; continue; }
                    Expect(s, ref i, '}');
                    return d;
                }
            }
            if (c == '[')
            {
                var l = new List<object>();
                i++;
                SkipWs(s, ref i);
                if (i < s.Length && s[i] == ']') { i++; return l; }
                while (true)
                {
                    l.Add(ReadValue(s, ref i));
                    SkipWs(s, ref i);
                    if (i < s.Length && s[i] == ',') { i++; continue; }
                    Expect(s, ref i, ']');
                    return l;
                }
            }
            if (c == '"') return ReadString(s, ref i);
            if (Word(s, ref i, "true")) return true;
            if (Word(s, ref i, "false")) return false;
            if (Word(s, ref i, "null")) return null;
            int start = i;
            while (i < s.Length && "+-0123456789.eE".IndexOf(s[i]) >= 0) i++;
            if (start == i) throw new FormatException("unexpected '" + c + "' at " + i);
            return ParseDouble(s.Substring(start, i - start));
        }

        /// <summary>
        /// A decimal number (JSON's grammar) to the nearest double, ties to even. Numbers of at
        /// most 2^53 in their digits and a power of ten within ±22 are one correctly rounded
        /// multiplication or division of two exact doubles (Clinger's fast path: most of what
        /// the server writes, at the cost of double.Parse); the rest take the runtime's
        /// double.Parse, then move by an ulp while the decimal's exact value lies beyond the
        /// midpoint to a neighbour (compared exactly, in integers).
        /// </summary>
        /// <exception cref="FormatException">Not a number.</exception>
        public static double ParseDouble(string text)
        {
            bool negative;
            ulong small;
            int exp10;
            bool fits = Decimal(text, out negative, out small, out exp10);
            if (fits && small == 0) return negative ? -0.0 : 0.0;
            if (fits && small <= (1UL << 53) && exp10 >= -22 && exp10 <= 22)
            {
                double d = small;
                d = exp10 >= 0 ? d * ExactPow10[exp10] : d / ExactPow10[-exp10];
                return negative ? -d : d;
            }
            double x = double.Parse(text, NumberStyles.Float, CultureInfo.InvariantCulture);
            if (x == 0 || double.IsInfinity(x) || double.IsNaN(x)) return x;
            BigInteger digits = fits ? new BigInteger(small) : LongDecimal(text, out exp10);
            double a = Math.Abs(x);
            for (int step = 0; step < 4; step++)
            {
                long bits = BitConverter.DoubleToInt64Bits(a);
                bool odd = (bits & 1) != 0;
                int up = CompareToMidpoint(digits, exp10, bits, true);
                if (up > 0 || (up == 0 && odd)) { a = BitConverter.Int64BitsToDouble(bits + 1); continue; }
                int down = CompareToMidpoint(digits, exp10, bits, false);
                if (down < 0 || (down == 0 && odd)) { a = BitConverter.Int64BitsToDouble(bits - 1); continue; }
                break;
            }
            return x < 0 ? -a : a;
        }

        // 10^0 … 10^22: every one an exact double.
        static readonly double[] ExactPow10 =
        {
            1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
            1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
        };

        // |text| = small · 10^exp10, read without allocating; false when its digits (leading
        // zeros aside) do not fit a ulong (then LongDecimal reads it).
        static bool Decimal(string text, out bool negative, out ulong small, out int exp10)
        {
            negative = false;
            small = 0;
            exp10 = 0;
            int i = 0, n = text.Length;
            if (i < n && (text[i] == '-' || text[i] == '+')) negative = text[i++] == '-';
            bool fits = true, dot = false;
            for (; i < n; i++)
            {
                char c = text[i];
                if (c == '.') { dot = true; continue; }
                if (c < '0' || c > '9') break;
                if (dot) exp10--;
                if (small > (ulong.MaxValue - 9) / 10) { fits = false; continue; }
                small = small * 10 + (ulong)(c - '0');
            }
            if (i < n && (text[i] == 'e' || text[i] == 'E'))
                exp10 += int.Parse(text.Substring(i + 1), NumberStyles.AllowLeadingSign, CultureInfo.InvariantCulture);
            return fits;
        }

        // |text| = digits · 10^exp10, for a decimal with more digits than a ulong holds.
        static BigInteger LongDecimal(string text, out int exp10)
        {
            string t = text.TrimStart('-', '+');
            int e = t.IndexOfAny(new[] { 'e', 'E' });
            exp10 = e < 0 ? 0 : int.Parse(t.Substring(e + 1), NumberStyles.AllowLeadingSign, CultureInfo.InvariantCulture);
            string mant = e < 0 ? t : t.Substring(0, e);
            int dot = mant.IndexOf('.');
            if (dot >= 0)
            {
                exp10 -= mant.Length - dot - 1;
                mant = mant.Remove(dot, 1);
            }
            return BigInteger.Parse(mant, CultureInfo.InvariantCulture);
        }

        // Compares digits·10^exp10 with the midpoint between the positive finite double of `bits`
        // and its upper (`up`) or lower neighbour: -1, 0 or 1.
        static int CompareToMidpoint(BigInteger digits, int exp10, long bits, bool up)
        {
            int field = (int)(bits >> 52);
            long frac = bits & ((1L << 52) - 1);
            long m = field == 0 ? frac : frac | (1L << 52);
            int k = field == 0 ? -1074 : field - 1075;
            // The midpoint n·2^p: (2m ± 1)·2^(k−1), or (4m − 1)·2^(k−2) below a binade's first double.
            BigInteger n;
            int p;
            if (up) { n = 2 * (BigInteger)m + 1; p = k - 1; }
            else if (frac == 0 && field > 1) { n = 4 * (BigInteger)m - 1; p = k - 2; }
            else { n = 2 * (BigInteger)m - 1; p = k - 1; }
            BigInteger l = digits, r = n;
            if (exp10 >= 0) l *= Pow10(exp10); else r *= Pow10(-exp10);
            if (p >= 0) r <<= p; else l <<= -p;
            return l.CompareTo(r);
        }

        // 10^e as an integer, cached (JSON numbers reach e ≈ 343; each is made once).
        static readonly BigInteger[] Pow10Cache = new BigInteger[400];
        static readonly bool[] Pow10Made = new bool[400];

        static BigInteger Pow10(int e)
        {
            if (e >= Pow10Cache.Length) return BigInteger.Pow(10, e);
            lock (Pow10Cache)
            {
                if (!Pow10Made[e]) { Pow10Cache[e] = BigInteger.Pow(10, e); Pow10Made[e] = true; }
                return Pow10Cache[e];
            }
        }

        static bool Word(string s, ref int i, string w)
        {
            if (string.CompareOrdinal(s, i, w, 0, w.Length) != 0) return false;
            i += w.Length;
            return true;
        }

        static void Expect(string s, ref int i, char c)
        {
            if (i >= s.Length || s[i] != c) throw new FormatException("expected '" + c + "' at " + i);
            i++;
        }

        static string ReadString(string s, ref int i)
        {
            Expect(s, ref i, '"');
            var sb = new StringBuilder();
            while (true)
            {
                if (i >= s.Length) throw new FormatException("unterminated string");
                char c = s[i++];
                if (c == '"') return sb.ToString();
                if (c != '\\') { sb.Append(c); continue; }
                char e = s[i++];
                switch (e)
                {
                    case '"': sb.Append('"'); break;
                    case '\\': sb.Append('\\'); break;
                    case '/': sb.Append('/'); break;
                    case 'b': sb.Append('\b'); break;
                    case 'f': sb.Append('\f'); break;
                    case 'n': sb.Append('\n'); break;
                    case 'r': sb.Append('\r'); break;
                    case 't': sb.Append('\t'); break;
                    case 'u':
                        sb.Append((char)int.Parse(s.Substring(i, 4), NumberStyles.HexNumber, CultureInfo.InvariantCulture));
                        i += 4;
                        break;
                    default: throw new FormatException("bad escape \\" + e);
                }
            }
        }

        /// <summary>Writes a value (dictionaries, lists and arrays, strings, numbers, bools, null).</summary>
        public static string Write(object v)
        {
            var sb = new StringBuilder();
            WriteValue(sb, v);
            return sb.ToString();
        }

        /// <summary>A double as JSON: the shortest form that reads back to the same bits.</summary>
        /// <exception cref="ArgumentException">NaN or an infinity (JSON has none).</exception>
        public static string Number(double x)
        {
            if (double.IsNaN(x) || double.IsInfinity(x)) throw new ArgumentException("JSON has no " + x);
            string r = x.ToString("R", CultureInfo.InvariantCulture);
            // Checked with the exact reader: Mono's "R" is checked with its own double.Parse, so
            // it can give 15 digits that read back (correctly) to a neighbour.
            if (BitConverter.DoubleToInt64Bits(ParseDouble(r)) != BitConverter.DoubleToInt64Bits(x))
                r = x.ToString("G17", CultureInfo.InvariantCulture);
            return r;
        }

        static void WriteValue(StringBuilder sb, object v)
        {
            if (v == null) { sb.Append("null"); return; }
            if (v is string) { WriteString(sb, (string)v); return; }
            if (v is bool) { sb.Append((bool)v ? "true" : "false"); return; }
            if (v is double) { sb.Append(Number((double)v)); return; }
            if (v is float) { sb.Append(Number((float)v)); return; }
            if (v is int || v is long || v is ulong || v is uint)
            {
                sb.Append(Convert.ToString(v, CultureInfo.InvariantCulture));
                return;
            }
            var dict = v as IDictionary<string, object>;
            if (dict != null)
            {
                sb.Append('{');
                bool first = true;
                foreach (var kv in dict)
                {
                    if (!first) sb.Append(',');
                    first = false;
                    WriteString(sb, kv.Key);
                    sb.Append(':');
                    WriteValue(sb, kv.Value);
                }
                sb.Append('}');
                return;
            }
            var list = v as System.Collections.IEnumerable;
            if (list != null)
            {
                sb.Append('[');
                bool first = true;
                foreach (var x in list)
                {
                    if (!first) sb.Append(',');
                    first = false;
                    WriteValue(sb, x);
                }
                sb.Append(']');
                return;
            }
            throw new ArgumentException("cannot write " + v.GetType() + " as JSON");
        }

        static void WriteString(StringBuilder sb, string s)
        {
            sb.Append('"');
            foreach (char c in s)
            {
                if (c == '"') sb.Append("\\\"");
                else if (c == '\\') sb.Append("\\\\");
                else if (c < 0x20) sb.Append("\\u").Append(((int)c).ToString("x4", CultureInfo.InvariantCulture));
                else sb.Append(c);
            }
            sb.Append('"');
        }

        // Accessors for parsed values: each throws FormatException naming the field when the
        // value has another type.

        /// <summary>The object at <paramref name="key"/>, or null when absent.</summary>
        public static object Get(object obj, string key)
        {
            var d = obj as Dictionary<string, object>;
            object v;
            return d != null && d.TryGetValue(key, out v) ? v : null;
        }

        /// <summary>A number field.</summary>
        public static double Num(object obj, string key)
        {
            object v = Get(obj, key);
            if (!(v is double)) throw new FormatException(key + " is not a number");
            return (double)v;
        }

        /// <summary>A number field, or <paramref name="fallback"/> when absent or null.</summary>
        public static double Num(object obj, string key, double fallback)
        {
            object v = Get(obj, key);
            return v is double ? (double)v : fallback;
        }

        /// <summary>A boolean field, or <paramref name="fallback"/> when absent.</summary>
        public static bool Bool(object obj, string key, bool fallback)
        {
            object v = Get(obj, key);
            return v is bool ? (bool)v : fallback;
        }

        /// <summary>A string field, or null.</summary>
        public static string Str(object obj, string key)
        {
            return Get(obj, key) as string;
        }

        /// <summary>An array field (empty when absent).</summary>
        public static List<object> List(object obj, string key)
        {
            return (Get(obj, key) as List<object>) ?? new List<object>();
        }

        /// <summary>An array of numbers.</summary>
        public static double[] Nums(object v)
        {
            var l = v as List<object>;
            if (l == null) throw new FormatException("not an array of numbers");
            var r = new double[l.Count];
            for (int i = 0; i < r.Length; i++) r[i] = (double)l[i];
            return r;
        }
    }
}
