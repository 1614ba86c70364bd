// A minimal protobuf encoder/decoder for the few stream messages this client uses
// (proto/swell/v1/stream.proto, query.proto): ClientMessage {ping, subscribe} out, and
// ServerMessage {pong, tick (full body states, impacts), error, clock} in. Hand-written so the package
// needs no Google.Protobuf; unknown fields are skipped, as protobuf requires.
using System;
using System.Collections.Generic;
using System.IO;
using System.Text;

namespace Swell
{
    /// <summary>What the server sent, decoded from either subprotocol.</summary>
    public sealed class ServerMessage
    {
        /// <summary>"pong", "tick", "clock", "error", or another type (answers this client does not decode).</summary>
        public string Type;
        /// <summary>The id of the request it answers (0: none).</summary>
        public ulong Id;
        /// <summary>Pong: the client's time, echoed.</summary>
        public double ClientTime;
        /// <summary>Pong: scene time; clock event: its t.</summary>
        public double SceneTime;
        /// <summary>Pong / clock event: floor(t·tick_hz).</summary>
        public long Tick;
        /// <summary>Pong / clock event: the clock's state.</summary>
        public ClockState Clock = new ClockState { Rate = 1, Generation = -1 };
        /// <summary>Clock event: ticks per scene second.</summary>
        public double TickHz;
        /// <summary>Clock event: Unix time of the reading.</summary>
        public double Unix;
        /// <summary>Tick frame.</summary>
        public TickFrame Frame;
        /// <summary>Error: code, message, field.</summary>
        public string Code, Message, Field;
        /// <summary>The JSON object (JSON subprotocol only).</summary>
        public object Raw;
    }

    /// <summary>The protobuf forms of the stream's messages.</summary>
    public static class Protobuf
    {
        // ---- writing ----

        static void Varint(Stream s, ulong v)
        {
            while (v >= 0x80) { s.WriteByte((byte)(v | 0x80)); v >>= 7; }
            s.WriteByte((byte)v);
        }

        static void Key(Stream s, int field, int wire) { Varint(s, (ulong)((field << 3) | wire)); }

        static void Double(Stream s, int field, double v)
        {
            if (BitConverter.DoubleToInt64Bits(v) == 0) return; // proto3 default (+0.0) omitted
            Key(s, field, 1);
            var b = BitConverter.GetBytes(v);
            if (!BitConverter.IsLittleEndian) Array.Reverse(b);
            s.Write(b, 0, 8);
        }

        static void Bytes(Stream s, int field, byte[] b)
        {
            Key(s, field, 2);
            Varint(s, (ulong)b.Length);
            s.Write(b, 0, b.Length);
        }

        static byte[] Message(Action<Stream> body)
        {
            var m = new MemoryStream();
            body(m);
            return m.ToArray();
        }

        /// <summary>ClientMessage {id, ping {client_time}}.</summary>
        public static byte[] Ping(ulong id, double clientTime)
        {
            return Message(s =>
            {
                Key(s, 1, 0); Varint(s, id);
                Bytes(s, 2, Message(p => Double(p, 1, clientTime)));
            });
        }

        /// <summary>ClientMessage {id, subscribe {ticks, bodies, region}}.</summary>
        public static byte[] Subscribe(ulong id, bool ticks, IList<ulong> bodies, double[] region)
        {
            return Message(s =>
            {
                Key(s, 1, 0); Varint(s, id);
                Bytes(s, 5, Message(p =>
                {
                    if (ticks) { Key(p, 1, 0); Varint(p, 1); }
                    if (bodies != null && bodies.Count > 0)
                    {
                        Bytes(p, 2, Message(q => { foreach (var b in bodies) Varint(q, b); }));
                    }
                    if (region != null)
                    {
                        Bytes(p, 3, Message(q =>
                        {
                            for (int i = 0; i < 4; i++) Double(q, i + 1, region[i]);
                        }));
                    }
                }));
            });
        }

        // ---- reading ----

        sealed class Reader
        {
            readonly byte[] b;
            int i;
            readonly int end;
            public Reader(byte[] b, int start, int end) { this.b = b; i = start; this.end = end; }
            public bool More { get { return i < end; } }
            public ulong Varint()
            {
                ulong v = 0;
                for (int shift = 0; shift < 64; shift += 7)
                {
                    if (i >= end) throw new FormatException("truncated varint");
                    byte x = b[i++];
                    v |= (ulong)(x & 0x7f) << shift;
                    if (x < 0x80) return v;
                }
                throw new FormatException("varint too long");
            }
            public double Double()
            {
                if (i + 8 > end) throw new FormatException("truncated double");
                long bits = 0;
                for (int k = 7; k >= 0; k--) bits = (bits << 8) | b[i + k];
                i += 8;
                return BitConverter.Int64BitsToDouble(bits);
            }
            public Reader Sub()
            {
                int len = checked((int)Varint());
                if (len < 0 || i + len > end) throw new FormatException("truncated field");
                var r = new Reader(b, i, i + len);
                i += len;
                return r;
            }
            public string String()
            {
                int len = checked((int)Varint());
                if (len < 0 || i + len > end) throw new FormatException("truncated string");
                var s = Encoding.UTF8.GetString(b, i, len);
                i += len;
                return s;
            }
            public void Skip(int wire)
            {
                switch (wire)
                {
                    case 0: Varint(); break;
                    case 1: i += 8; break;
                    case 2: { int len = checked((int)Varint()); i += len; break; }
                    case 5: i += 4; break;
                    default: throw new FormatException("unsupported wire type " + wire);
                }
                if (i > end) throw new FormatException("truncated field");
            }
        }

        /// <summary>Decodes a ServerMessage.</summary>
        /// <exception cref="FormatException">Not a well-formed message.</exception>
        public static ServerMessage Decode(byte[] bytes)
        {
            var m = new ServerMessage { Type = "unknown" };
            var r = new Reader(bytes, 0, bytes.Length);
            while (r.More)
            {
                ulong key = r.Varint();
                int field = (int)(key >> 3), wire = (int)(key & 7);
                if (field == 1 && wire == 0) m.Id = r.Varint();
                else if (field == 2 && wire == 2) { m.Type = "pong"; Pong(r.Sub(), m); }
                else if (field == 5 && wire == 2) { m.Type = "tick"; m.Frame = Tick(r.Sub()); }
                else if (field == 6 && wire == 2) { m.Type = "error"; Error(r.Sub(), m); }
                else if (field == 7 && wire == 2) { m.Type = "clock"; ClockChange(r.Sub(), m); }
                else if (field == 3 && wire == 2) { m.Type = "sample_result"; r.Skip(wire); }
                else if (field == 4 && wire == 2) { m.Type = "orientation_result"; r.Skip(wire); }
                else r.Skip(wire);
            }
            return m;
        }

        static void Pong(Reader r, ServerMessage m)
        {
            m.Clock = new ClockState { Rate = 0, Paused = false, Generation = 0 };
            while (r.More)
            {
                ulong key = r.Varint();
                int f = (int)(key >> 3), w = (int)(key & 7);
                if (f == 1 && w == 1) m.ClientTime = r.Double();
                else if (f == 2 && w == 1) m.SceneTime = r.Double();
                else if (f == 3 && w == 0) m.Tick = (long)r.Varint();
                else if (f == 4 && w == 1) m.Clock.Rate = r.Double();
                else if (f == 5 && w == 0) m.Clock.Paused = r.Varint() != 0;
                else if (f == 6 && w == 0) m.Clock.Generation = (long)r.Varint();
                else r.Skip(w);
            }
        }

        static void ClockChange(Reader r, ServerMessage m)
        {
            m.Clock = new ClockState { Rate = 0, Paused = false, Generation = 0 };
            while (r.More)
            {
                ulong key = r.Varint();
                int f = (int)(key >> 3), w = (int)(key & 7);
                if (f == 1 && w == 1) m.SceneTime = r.Double();
                else if (f == 2 && w == 0) m.Tick = (long)r.Varint();
                else if (f == 3 && w == 1) m.TickHz = r.Double();
                else if (f == 4 && w == 1) m.Clock.Rate = r.Double();
                else if (f == 5 && w == 0) m.Clock.Paused = r.Varint() != 0;
                else if (f == 6 && w == 1) m.Unix = r.Double();
                else if (f == 7 && w == 0) m.Clock.Generation = (long)r.Varint();
                else r.Skip(w);
            }
        }

        static void Error(Reader r, ServerMessage m)
        {
            while (r.More)
            {
                ulong key = r.Varint();
                int f = (int)(key >> 3), w = (int)(key & 7);
                if (f == 1 && w == 2) m.Code = r.String();
                else if (f == 2 && w == 2) m.Message = r.String();
                else if (f == 3 && w == 2) m.Field = r.String();
                else r.Skip(w);
            }
        }

        static double[] Vec(Reader r, int n)
        {
            var v = new double[n];
            while (r.More)
            {
                ulong key = r.Varint();
                int f = (int)(key >> 3), w = (int)(key & 7);
                if (f >= 1 && f <= n && w == 1) v[f - 1] = r.Double();
                else r.Skip(w);
            }
            return v;
        }

        static TickFrame Tick(Reader r)
        {
            var t = new TickFrame();
            while (r.More)
            {
                ulong key = r.Varint();
                int f = (int)(key >> 3), w = (int)(key & 7);
                if (f == 1 && w == 0) t.Tick = (long)r.Varint();
                else if (f == 2 && w == 1) t.T = r.Double();
                else if (f == 3 && w == 2) t.Bodies.Add(Body(r.Sub()));
                else if (f == 5 && w == 2) t.Impacts.Add(Impact(r.Sub()));
                else if (f == 6 && w == 0) t.AnchorTick = (long)r.Varint();
                else r.Skip(w); // compact bodies (not asked for)
            }
            return t;
        }

        static ImpactEvent Impact(Reader r)
        {
            var e = new ImpactEvent();
            while (r.More)
            {
                ulong key = r.Varint();
                int f = (int)(key >> 3), w = (int)(key & 7);
                if (f == 1 && w == 0) e.Tick = (long)r.Varint();
                else if (f == 2 && w == 1) e.T = r.Double();
                else if (f == 3 && w == 1) e.Position[0] = r.Double();
                else if (f == 4 && w == 1) e.Position[1] = r.Double();
                else if (f == 5 && w == 1) e.Strength = r.Double();
                else if (f == 6 && w == 1) e.Radius = r.Double();
                else if (f == 7 && w == 0) e.BodyTick = (long)r.Varint();
                else r.Skip(w);
            }
            return e;
        }

        static BodyState Body(Reader r)
        {
            var b = new BodyState();
            while (r.More)
            {
                ulong key = r.Varint();
                int f = (int)(key >> 3), w = (int)(key & 7);
                if (f == 1 && w == 0) b.Id = r.Varint();
                else if (f == 2 && w == 2) b.Position = Vec(r.Sub(), 3);
                else if (f == 3 && w == 2) b.Rotation = Vec(r.Sub(), 4);
                else if (f == 4 && w == 2) b.Velocity = Vec(r.Sub(), 3);
                else if (f == 5 && w == 2) b.AngularVelocity = Vec(r.Sub(), 3);
                else if (f == 6 && w == 1) b.Submerged = r.Double();
                else if (f == 7 && w == 0) b.Quarantined = r.Varint() != 0;
                else r.Skip(w);
            }
            return b;
        }
    }
}
