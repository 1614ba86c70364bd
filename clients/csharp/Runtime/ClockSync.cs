// Clock synchronisation from ping/pong samples: a port of ClockSync in clients/js/src/session.js.
//
// One fit describes one clock generation (the server counts every seek, rate or pause change and
// every put that moves the epoch; pongs and clock events carry it): the session starts a new
// ClockSync at each new generation, so samples from before a change never mix with those after it.
// The scene clock runs at the rate the server states (slope k = rate, or 0 while paused), so each
// sample gives the offset of sceneTime − k·mid, and the fitted drift is only the two machines'
// clock-frequency error.
using System;
using System.Collections.Generic;

namespace Swell
{
    /// <summary>A scene clock's state as a pong or clock event states it.</summary>
    public struct ClockState
    {
        /// <summary>Scene seconds per real second.</summary>
        public double Rate;
        /// <summary>Whether the clock is paused.</summary>
        public bool Paused;
        /// <summary>The clock's generation (-1: a server that sends none).</summary>
        public long Generation;
    }

    /// <summary>Scene time from ping/pong samples (seconds on both clocks).</summary>
    public sealed class ClockSync
    {
        struct S { public double Rtt, Mid, Offset; }

        readonly int window, best;
        readonly List<S> samples = new List<S>();

        /// <summary>Offset of sceneTime − slope·clientTime at <see cref="Ref"/>, s.</summary>
        public double Offset = double.NaN;
        /// <summary>Fitted frequency error of the two clocks.</summary>
        public double Drift;
        /// <summary>Reference client time of the offset, s.</summary>
        public double Ref;
        /// <summary>Round trip of the last sample, s.</summary>
        public double Rtt = double.NaN;
        /// <summary>Lowest round trip, s.</summary>
        public double MinRtt = double.NaN;
        /// <summary>The clock this fit describes.</summary>
        public ClockState Clock;
        bool hasProvisional;
        double provAt, provT;

        /// <summary>A fit of window samples, the offset from the best lowest-RTT ones, for a clock in state c.</summary>
        public ClockSync(ClockState c, int window = 32, int best = 4)
        {
            this.window = window;
            this.best = best;
            Clock = c;
        }

        /// <summary>Scene seconds per client second: the rate, or 0 while paused.</summary>
        public double Slope { get { return Clock.Paused ? 0 : Clock.Rate; } }

        /// <summary>Samples held.</summary>
        public int Count { get { return samples.Count; } }

        /// <summary>Whether there is a sample (or a clock event's reading).</summary>
        public bool Synced { get { return samples.Count > 0 || hasProvisional; } }

        /// <summary>Until the first sample: the scene time t a clock event read at client time at.</summary>
        public void SetProvisional(double at, double t)
        {
            hasProvisional = true;
            provAt = at;
            provT = t;
        }

        /// <summary>Adds a sample: ping sent at sent, pong received at received (client clock), the pong's scene time.</summary>
        public void Add(double sent, double received, double sceneTime)
        {
            double rtt = received - sent;
            double mid = sent + rtt / 2;
            samples.Add(new S { Rtt = rtt, Mid = mid, Offset = sceneTime - Slope * mid });
            if (samples.Count > window) samples.RemoveAt(0);
            Rtt = rtt;
            var sorted = new List<S>(samples);
            sorted.Sort((a, b) => a.Rtt.CompareTo(b.Rtt));
            double minRtt = sorted[0].Rtt;
            // The lowest-RTT samples, leaving out any over twice the best round trip (+ 1 ms): a
            // round trip held up on one side carries up to all of its extra delay into its
            // offset, and just after a clock change, with a handful of samples, one such would
            // be averaged in.
            int nGood = 1;
            while (nGood < Math.Min(best, sorted.Count) && sorted[nGood].Rtt <= 2 * minRtt + 1e-3) nGood++;
            // Drift: slope of offset against time over the samples within twice the best RTT
            // (a spread of at least a second; none while paused).
            var within = samples.FindAll(s => s.Rtt <= 2 * minRtt + 1e-3);
            double m0 = 0, o0 = 0;
            foreach (var s in within) { m0 += s.Mid; o0 += s.Offset; }
            m0 /= within.Count;
            o0 /= within.Count;
            double sxx = 0, sxy = 0;
            foreach (var s in within) { sxx += (s.Mid - m0) * (s.Mid - m0); sxy += (s.Mid - m0) * (s.Offset - o0); }
            double span = within.Count > 1 ? within[within.Count - 1].Mid - within[0].Mid : 0;
            Drift = Slope != 0 && span >= 1 && sxx > 0 ? sxy / sxx : 0;
            double r = 0;
            for (int i = 0; i < nGood; i++) r += sorted[i].Mid;
            Ref = r / nGood;
            double o = 0;
            for (int i = 0; i < nGood; i++) o += sorted[i].Offset + Drift * (Ref - sorted[i].Mid);
            Offset = o / nGood;
            MinRtt = minRtt;
        }

        /// <summary>Scene time at client time c, s.</summary>
        public double SceneTime(double c)
        {
            if (samples.Count == 0 && hasProvisional) return provT + Slope * (c - provAt);
            return Slope * c + Offset + Drift * (c - Ref);
        }
    }
}
