// Body-state interpolation by the JS client's rules (clients/js/src/interp.js): render bodies at
// server time minus a delay, between the two tick frames around that time. Beyond the newest
// frame the state is extrapolated along its velocity for at most MaxExtrapolation seconds and
// flagged; before the oldest it is held and flagged. A frame older than the newest (the clock
// ran back or seeked) resets the buffer.
using System;
using System.Collections.Generic;

namespace Swell
{
    /// <summary>A floating body's state in a tick frame.</summary>
    public sealed class BodyState
    {
        /// <summary>Body id.</summary>
        public ulong Id;
        /// <summary>Position (x, y, z), m.</summary>
        public double[] Position = new double[3];
        /// <summary>Rotation quaternion (x, y, z, w).</summary>
        public double[] Rotation = { 0, 0, 0, 1 };
        /// <summary>Velocity, m/s.</summary>
        public double[] Velocity = new double[3];
        /// <summary>Angular velocity, rad/s.</summary>
        public double[] AngularVelocity = new double[3];
        /// <summary>Submerged fraction, 0..1.</summary>
        public double Submerged;
        /// <summary>Whether the last step was rolled back.</summary>
        public bool Quarantined;
    }

    /// <summary>A tick frame.</summary>
    public sealed class TickFrame
    {
        /// <summary>Tick number.</summary>
        public long Tick;
        /// <summary>The tick's scene time, s.</summary>
        public double T;
        /// <summary>Body states carried.</summary>
        public List<BodyState> Bodies = new List<BodyState>();
        /// <summary>Scene tick the scene's body world is anchored at (null while the scene has no bodies).
        /// A change means a clock jump re-anchored it: a native world replaying bodies is rebuilt
        /// from GET …/bodies (docs/clients.md, Native engines).</summary>
        public long? AnchorTick;
        /// <summary>Impacts accepted since the previous frame (usually none), in both subprotocols.</summary>
        public List<ImpactEvent> Impacts = new List<ImpactEvent>();
    }

    /// <summary>An impact on the scene's particle layer, as a tick frame carries it.</summary>
    public sealed class ImpactEvent
    {
        /// <summary>First tick at or after T: ceil(T·tick_hz).</summary>
        public long Tick;
        /// <summary>Scene time of the impact, s.</summary>
        public double T;
        /// <summary>World position (x, z), m.</summary>
        public double[] Position = new double[2];
        /// <summary>Splash height at the impact point, m.</summary>
        public double Strength;
        /// <summary>Particle radius of the ring, m.</summary>
        public double Radius;
        /// <summary>For an API impact on a scene with bodies: the scene tick the server's bodies feel
        /// it from (the POST answer's body_tick), which a native world replaying the bodies feels it
        /// at (crates/swell-ffi: swell_world_feel_impact). Null for impacts the bodies made (splashes,
        /// wakes: a native world derives them) and on scenes without bodies.</summary>
        public long? BodyTick;
    }

    /// <summary>How an interpolated state was obtained.</summary>
    public enum InterpMode
    {
        /// <summary>Between two frames.</summary>
        Interpolated,
        /// <summary>Past the newest frame, along its velocity (at most MaxExtrapolation).</summary>
        Extrapolated,
        /// <summary>Past that bound, or before the oldest frame.</summary>
        Held,
    }

    /// <summary>One body at one time.</summary>
    public struct InterpolatedBody
    {
        /// <summary>Body id.</summary>
        public ulong Id;
        /// <summary>Scene time asked, s.</summary>
        public double T;
        /// <summary>Tick of the frame it came from.</summary>
        public long Tick;
        /// <summary>Position, m.</summary>
        public double[] Position;
        /// <summary>Rotation (x, y, z, w).</summary>
        public double[] Rotation;
        /// <summary>How it was obtained.</summary>
        public InterpMode Mode;
    }

    /// <summary>A bounded buffer of tick frames and the states between them.</summary>
    public sealed class BodyInterpolator
    {
        sealed class F
        {
            public TickFrame Frame;
            public Dictionary<ulong, BodyState> ById;
        }

        /// <summary>Seconds behind server time to render (0.1 = 3 ticks at 30 Hz).</summary>
        public double Delay;
        /// <summary>Frames kept.</summary>
        public int Capacity;
        /// <summary>Longest extrapolation past the newest frame, s.</summary>
        public double MaxExtrapolation;
        readonly List<F> frames = new List<F>();
        readonly object gate = new object();

        /// <summary>A buffer (defaults as the JS client's).</summary>
        public BodyInterpolator(double delay = 0.1, int capacity = 64, double maxExtrapolation = 0.25)
        {
            Delay = delay;
            Capacity = capacity;
            MaxExtrapolation = maxExtrapolation;
        }

        /// <summary>Frames buffered.</summary>
        public int Count { get { lock (gate) return frames.Count; } }

        /// <summary>Adds a tick frame (safe to call from the session's receive thread).</summary>
        public void Push(TickFrame frame)
        {
            lock (gate)
            {
                if (frames.Count > 0)
                {
                    var last = frames[frames.Count - 1].Frame;
                    if (frame.T <= last.T)
                    {
                        if (frame.T == last.T) return;
                        frames.Clear();
                    }
                }
                var byId = new Dictionary<ulong, BodyState>();
                foreach (var b in frame.Bodies) byId[b.Id] = b;
                frames.Add(new F { Frame = frame, ById = byId });
                if (frames.Count > Capacity) frames.RemoveAt(0);
            }
        }

        /// <summary>States at serverTime − Delay.</summary>
        public Dictionary<ulong, InterpolatedBody> At(double serverTime)
        {
            return Sample(serverTime - Delay);
        }

        /// <summary>Every body's state at scene time t.</summary>
        public Dictionary<ulong, InterpolatedBody> Sample(double t)
        {
            var o = new Dictionary<ulong, InterpolatedBody>();
            lock (gate)
            {
                if (frames.Count == 0) return o;
                var newest = frames[frames.Count - 1].Frame;
                if (t >= newest.T)
                {
                    double dt = Math.Min(t - newest.T, MaxExtrapolation);
                    InterpMode mode = t - newest.T <= MaxExtrapolation ? (t == newest.T ? InterpMode.Interpolated : InterpMode.Extrapolated) : InterpMode.Held;
                    foreach (var b in newest.Bodies)
                    {
                        var p = new double[3];
                        for (int i = 0; i < 3; i++) p[i] = b.Position[i] + b.Velocity[i] * dt;
                        o[b.Id] = new InterpolatedBody { Id = b.Id, T = t, Mode = mode, Tick = newest.Tick, Position = p, Rotation = b.Rotation };
                    }
                    return o;
                }
                var oldest = frames[0].Frame;
                if (t <= oldest.T)
                {
                    foreach (var b in oldest.Bodies)
                        o[b.Id] = new InterpolatedBody { Id = b.Id, T = t, Mode = InterpMode.Held, Tick = oldest.Tick, Position = b.Position, Rotation = b.Rotation };
                    return o;
                }
                int k = frames.Count - 1;
                while (k > 0 && frames[k - 1].Frame.T > t) k--;
                var fa = frames[k - 1];
                var fb = frames[k];
                double u = (t - fa.Frame.T) / (fb.Frame.T - fa.Frame.T);
                foreach (var sb in fb.Frame.Bodies)
                {
                    BodyState sa;
                    if (!fa.ById.TryGetValue(sb.Id, out sa))
                    {
                        o[sb.Id] = new InterpolatedBody { Id = sb.Id, T = t, Mode = InterpMode.Held, Tick = fb.Frame.Tick, Position = sb.Position, Rotation = sb.Rotation };
                        continue;
                    }
                    var p = new double[3];
                    for (int i = 0; i < 3; i++) p[i] = sa.Position[i] + (sb.Position[i] - sa.Position[i]) * u;
                    o[sb.Id] = new InterpolatedBody { Id = sb.Id, T = t, Mode = InterpMode.Interpolated, Tick = fa.Frame.Tick, Position = p, Rotation = Slerp(sa.Rotation, sb.Rotation, u) };
                }
            }
            return o;
        }

        /// <summary>Spherical interpolation between unit quaternions (x, y, z, w), shortest arc.</summary>
        public static double[] Slerp(double[] a, double[] b, double u)
        {
            double dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
            var bb = (double[])b.Clone();
            if (dot < 0)
            {
                dot = -dot;
                for (int i = 0; i < 4; i++) bb[i] = -bb[i];
            }
            var q = new double[4];
            if (dot > 0.9995)
            {
                for (int i = 0; i < 4; i++) q[i] = a[i] + (bb[i] - a[i]) * u;
                double n = Math.Sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
                for (int i = 0; i < 4; i++) q[i] /= n;
                return q;
            }
            double th = Math.Acos(dot);
            double s = Math.Sin(th);
            double wa = Math.Sin((1 - u) * th) / s, wb = Math.Sin(u * th) / s;
            for (int i = 0; i < 4; i++) q[i] = wa * a[i] + wb * bb[i];
            return q;
        }
    }
}
