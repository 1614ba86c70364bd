// The WebSocket session of a scene's stream (GET /v1/scenes/{id}/stream), over
// System.Net.WebSockets.ClientWebSocket, in either subprotocol (swell.v1.json or
// swell.v1.protobuf). The rules are the JS client's (clients/js/src/session.js):
//
// - Clock sync: pings every PingInterval; each pong gives a sample and the clock's rate, pause
//   flag and generation (ClockSync). A `clock` event (an admin seek, rate or pause change, or a
//   scene put that moves the epoch) or a pong of a newer generation restarts the fit; until the
//   next pong ServerTime() follows the event's reading at its rate, and ResyncPings pings go out at
//   once. A pong of an older generation (answered before a change the session already restarted at)
//   is dropped.
// - Tick subscription by body ids and/or a region; frames go to OnTick and the Interpolator.
// - Events are raised on the receive thread: in Unity or Godot, hand them to the main thread
//   (or read ServerTime()/Interpolator from the main thread, which are safe to call anywhere).
// - No automatic reconnect: after Closed fires, make a new session (the JS client reconnects
//   by itself; this port leaves the policy to the game). CloseStatus and CloseReason say why:
//   4404 (SceneGone) means the scene was deleted, and a new session would be refused (404).
// - Errors the server sends that answer no request (the scene was deleted, a rate limit) go to
//   OnError.
using System;
using System.Collections.Concurrent;
using System.Collections.Generic;
using System.Diagnostics;
using System.IO;
using System.Net.WebSockets;
using System.Text;
using System.Threading;
using System.Threading.Tasks;

namespace Swell
{
    /// <summary>The stream's subprotocols.</summary>
    public enum Wire
    {
        /// <summary>swell.v1.json: text frames.</summary>
        Json,
        /// <summary>swell.v1.protobuf: binary frames.</summary>
        Protobuf,
    }

    /// <summary>A session on one scene's stream.</summary>
    public sealed class SwellSession : IDisposable
    {
        /// <summary>Subprotocol.</summary>
        public readonly Wire Wire;
        /// <summary>Ping period, ms.</summary>
        public int PingIntervalMs = 1000;
        /// <summary>Pings ConnectAsync waits for.</summary>
        public int SyncPings = 5;
        /// <summary>Pings sent at once at a clock change.</summary>
        public int ResyncPings = 3;
        /// <summary>How long a ping waits for its pong, ms.</summary>
        public int RequestTimeoutMs = 10000;
        /// <summary>Fed every tick frame, if set.</summary>
        public BodyInterpolator Interpolator;
        /// <summary>Every tick frame (receive thread).</summary>
        public event Action<TickFrame> OnTick;
        /// <summary>The scene's clock changed (receive thread).</summary>
        public event Action<ClockReading> OnClock;
        /// <summary>The socket closed (see CloseStatus, CloseReason).</summary>
        public event Action Closed;
        /// <summary>An error the server sent that answers no request of this session, e.g.
        /// not_found when the scene is deleted (receive thread).</summary>
        public event Action<SwellException> OnError;
        /// <summary>The Close code of a session whose scene was deleted.</summary>
        public const int SceneGone = 4404;
        /// <summary>The server's Close code, once it closed the socket (null before, or when the
        /// connection dropped without one).</summary>
        public int? CloseStatus { get; private set; }
        /// <summary>The server's Close reason (empty when none).</summary>
        public string CloseReason { get; private set; }
        /// <summary>The client clock, s (default a monotonic stopwatch).</summary>
        public Func<double> Now;

        readonly Uri url;
        readonly ClientWebSocket ws = new ClientWebSocket();
        readonly SemaphoreSlim sendLock = new SemaphoreSlim(1, 1);
        readonly ConcurrentDictionary<ulong, TaskCompletionSource<ServerMessage>> pending = new ConcurrentDictionary<ulong, TaskCompletionSource<ServerMessage>>();
        readonly CancellationTokenSource stop = new CancellationTokenSource();
        readonly object clockGate = new object();
        ClockSync clock = new ClockSync(new ClockState { Rate = 1, Generation = -1 });
        long nextId;
        /// <summary>The receive loop (ends when the socket closes).</summary>
        public Task ReceiveTask { get; private set; }
        Task pingTask;
        static readonly Stopwatch Watch = Stopwatch.StartNew();

        /// <summary>The last tick frame received.</summary>
        public TickFrame LastTick { get; private set; }
        /// <summary>The last clock event received (Generation -1 before one).</summary>
        public ClockReading LastClock { get; private set; }

        /// <summary>A session on url (ws://host:port/v1/scenes/{id}/stream; see SwellClient.StreamUrl).</summary>
        public SwellSession(string url, Wire wire = Wire.Json)
        {
            this.url = new Uri(url);
            Wire = wire;
            Now = () => Watch.Elapsed.TotalSeconds;
            LastClock = new ClockReading { Generation = -1 };
            ws.Options.AddSubProtocol(wire == Wire.Json ? "swell.v1.json" : "swell.v1.protobuf");
        }

        /// <summary>Opens the socket, starts the receive and ping loops, and waits for SyncPings pongs.</summary>
        public async Task ConnectAsync(CancellationToken ct = default(CancellationToken))
        {
            try
            {
                await ws.ConnectAsync(url, ct).ConfigureAwait(false);
            }
            catch (WebSocketException e)
            {
                // The upgrade's status is not exposed: a missing scene (404) and a server that
                // is down look the same here.
                throw new SwellException(0, "unreachable", "cannot open " + url + ": the scene does not exist (404) or the server cannot be reached (" + e.Message + ")", null);
            }
            string expect = Wire == Wire.Json ? "swell.v1.json" : "swell.v1.protobuf";
            if (ws.SubProtocol != expect) throw new SwellException(0, "subprotocol", "the server chose subprotocol " + ws.SubProtocol + ", not " + expect, null);
            ReceiveTask = Task.Run(() => ReceiveLoop());
            pingTask = Task.Run(() => PingLoop());
            await SyncNow(SyncPings).ConfigureAwait(false);
        }

        async Task PingLoop()
        {
            while (!stop.IsCancellationRequested)
            {
                try { await Task.Delay(PingIntervalMs, stop.Token).ConfigureAwait(false); }
                catch (OperationCanceledException) { return; }
                try { await Ping().ConfigureAwait(false); }
                catch (Exception) { /* the next one, or Closed */ }
            }
        }

        async Task ReceiveLoop()
        {
            var buf = new byte[64 * 1024];
            var msg = new MemoryStream();
            try
            {
                while (ws.State == WebSocketState.Open && !stop.IsCancellationRequested)
                {
                    msg.SetLength(0);
                    WebSocketReceiveResult r;
                    do
                    {
                        r = await ws.ReceiveAsync(new ArraySegment<byte>(buf), stop.Token).ConfigureAwait(false);
                        if (r.MessageType == WebSocketMessageType.Close)
                        {
                            CloseStatus = r.CloseStatus.HasValue ? (int?)(int)r.CloseStatus.Value : null;
                            CloseReason = r.CloseStatusDescription ?? "";
                            return;
                        }
                        msg.Write(buf, 0, r.Count);
                    } while (!r.EndOfMessage);
                    double received = Now();
                    ServerMessage m;
                    try
                    {
                        m = r.MessageType == WebSocketMessageType.Text ? DecodeJson(Encoding.UTF8.GetString(msg.GetBuffer(), 0, (int)msg.Length)) : Protobuf.Decode(msg.ToArray());
                    }
                    catch (FormatException) { continue; }
                    Handle(m, received);
                }
            }
            catch (Exception) { /* closed or aborted */ }
            finally
            {
                foreach (var kv in pending) kv.Value.TrySetException(new SwellException(0, "closed", "socket closed before the answer", null));
                pending.Clear();
                var c = Closed;
                if (c != null) c();
            }
        }

        static ServerMessage DecodeJson(string text)
        {
            object o = Json.Parse(text);
            var m = new ServerMessage { Type = Json.Str(o, "type") ?? "unknown", Raw = o };
            m.Id = (ulong)Json.Num(o, "id", 0);
            switch (m.Type)
            {
                case "pong":
                    m.ClientTime = Json.Num(o, "client_time");
                    m.SceneTime = Json.Num(o, "scene_time");
                    m.Tick = (long)Json.Num(o, "tick");
                    m.Clock = new ClockState { Rate = Json.Num(o, "rate", 1), Paused = Json.Bool(o, "paused", false), Generation = (long)Json.Num(o, "generation", -1) };
                    break;
                case "clock":
                    m.SceneTime = Json.Num(o, "t");
                    m.Tick = (long)Json.Num(o, "tick");
                    m.TickHz = Json.Num(o, "tick_hz");
                    m.Unix = Json.Num(o, "unix");
                    m.Clock = new ClockState { Rate = Json.Num(o, "rate"), Paused = Json.Bool(o, "paused", false), Generation = (long)Json.Num(o, "generation", -1) };
                    break;
                case "tick":
                    var f = new TickFrame { Tick = (long)Json.Num(o, "tick"), T = Json.Num(o, "t") };
                    if (Json.Get(o, "anchor_tick") is double) f.AnchorTick = (long)Json.Num(o, "anchor_tick");
                    foreach (var b in Json.List(o, "bodies"))
                    {
                        f.Bodies.Add(new BodyState
                        {
                            Id = (ulong)Json.Num(b, "id"),
                            Position = Json.Nums(Json.Get(b, "position")),
                            Rotation = Json.Nums(Json.Get(b, "rotation")),
                            Velocity = Json.Nums(Json.Get(b, "velocity")),
                            AngularVelocity = Json.Nums(Json.Get(b, "angular_velocity")),
                            Submerged = Json.Num(b, "submerged", 0),
                            Quarantined = Json.Bool(b, "quarantined", false),
                        });
                    }
                    foreach (var e in Json.List(o, "impacts"))
                    {
                        f.Impacts.Add(new ImpactEvent
                        {
                            Tick = (long)Json.Num(e, "tick"),
                            T = Json.Num(e, "t"),
                            Position = Json.Nums(Json.Get(e, "position")),
                            Strength = Json.Num(e, "strength"),
                            Radius = Json.Num(e, "radius"),
                            BodyTick = Json.Get(e, "body_tick") is double ? (long?)(long)Json.Num(e, "body_tick") : null,
                        });
                    }
                    m.Frame = f;
                    break;
                case "error":
                    m.Code = Json.Str(o, "code");
                    m.Message = Json.Str(o, "message");
                    m.Field = Json.Str(o, "field");
                    break;
            }
            return m;
        }

        void Handle(ServerMessage m, double received)
        {
            if (m.Type == "tick")
            {
                LastTick = m.Frame;
                if (Interpolator != null) Interpolator.Push(m.Frame);
                var h = OnTick;
                if (h != null) h(m.Frame);
                return;
            }
            if (m.Type == "clock")
            {
                var reading = new ClockReading { T = m.SceneTime, Tick = m.Tick, TickHz = m.TickHz, Rate = m.Clock.Rate, Paused = m.Clock.Paused, Unix = m.Unix, Generation = m.Clock.Generation };
                lock (clockGate)
                {
                    // The event left the server about one one-way delay before it arrived.
                    double oneWay = double.IsNaN(clock.MinRtt) ? 0 : clock.MinRtt / 2;
                    clock = new ClockSync(m.Clock);
                    clock.SetProvisional(received - oneWay, m.SceneTime);
                }
                LastClock = reading;
                var h = OnClock;
                if (h != null) h(reading);
                if (ws.State == WebSocketState.Open) Task.Run(() => SyncNow(ResyncPings)).ContinueWith(t => { var e = t.Exception; });
                return;
            }
            TaskCompletionSource<ServerMessage> p;
            if (m.Id == 0 || !pending.TryRemove(m.Id, out p))
            {
                var onError = OnError;
                if (m.Type == "error" && onError != null) onError(new SwellException(0, m.Code, m.Message, m.Field));
                return;
            }
            if (m.Type == "error")
            {
                p.TrySetException(new SwellException(400, m.Code, m.Message, m.Field));
                return;
            }
            if (m.Type == "pong")
            {
                lock (clockGate)
                {
                    long g = m.Clock.Generation, cur = clock.Clock.Generation;
                    if (g >= 0 && cur >= 0 && g < cur)
                    {
                        // Answered before a change this session already restarted at.
                    }
                    else
                    {
                        if (g != cur || !clock.Synced) clock = new ClockSync(m.Clock);
                        clock.Add(m.ClientTime, received, m.SceneTime);
                    }
                }
            }
            p.TrySetResult(m);
        }

        async Task Send(byte[] bytes, WebSocketMessageType type)
        {
            await sendLock.WaitAsync().ConfigureAwait(false);
            try { await ws.SendAsync(new ArraySegment<byte>(bytes), type, true, stop.Token).ConfigureAwait(false); }
            finally { sendLock.Release(); }
        }

        async Task<ServerMessage> Request(Func<ulong, byte[]> json, Func<ulong, byte[]> proto)
        {
            ulong id = (ulong)Interlocked.Increment(ref nextId);
            var tcs = new TaskCompletionSource<ServerMessage>(TaskCreationOptions.RunContinuationsAsynchronously);
            pending[id] = tcs;
            try
            {
                if (Wire == Wire.Json) await Send(json(id), WebSocketMessageType.Text).ConfigureAwait(false);
                else await Send(proto(id), WebSocketMessageType.Binary).ConfigureAwait(false);
            }
            catch (Exception e)
            {
                pending.TryRemove(id, out tcs);
                throw new SwellException(0, "transport", "send failed: " + e.Message, null);
            }
            var done = await Task.WhenAny(tcs.Task, Task.Delay(RequestTimeoutMs)).ConfigureAwait(false);
            if (done != tcs.Task)
            {
                pending.TryRemove(id, out tcs);
                throw new SwellException(0, "timeout", "no answer within " + RequestTimeoutMs + " ms", null);
            }
            return await tcs.Task.ConfigureAwait(false);
        }

        /// <summary>One ping: the pong, and a clock sample.</summary>
        public Task<ServerMessage> Ping()
        {
            double now = Now();
            return Request(
                id => Encoding.UTF8.GetBytes("{\"type\":\"ping\",\"id\":" + id + ",\"client_time\":" + Json.Number(now) + "}"),
                id => Protobuf.Ping(id, now));
        }

        /// <summary>n pings one after another (so their round trips do not inflate each other).</summary>
        public async Task SyncNow(int n)
        {
            for (int i = 0; i < n; i++) await Ping().ConfigureAwait(false);
        }

        /// <summary>Scene time now, s, from the synced clock.</summary>
        /// <exception cref="InvalidOperationException">Not synced yet (await ConnectAsync).</exception>
        public double ServerTime()
        {
            lock (clockGate)
            {
                if (!clock.Synced) throw new InvalidOperationException("the clock is not synced yet: await ConnectAsync()");
                return clock.SceneTime(Now());
            }
        }

        /// <summary>The current fit (generation, rate, samples, round trips).</summary>
        public ClockSync Clock { get { lock (clockGate) return clock; } }

        /// <summary>Subscribes to tick frames: bodies (ids) and/or region (x0, z0, x1, z1); neither: all bodies.</summary>
        public Task Subscribe(IList<ulong> bodies = null, double[] region = null)
        {
            if (region != null && (region.Length != 4 || region[0] > region[2] || region[1] > region[3]))
                throw new ArgumentException("region must be [x0, z0, x1, z1] with x0 <= x1 and z0 <= z1", "region");
            ulong id = (ulong)Interlocked.Increment(ref nextId);
            if (Wire == Wire.Protobuf) return Send(Protobuf.Subscribe(id, true, bodies, region), WebSocketMessageType.Binary);
            var msg = new Dictionary<string, object> { { "type", "subscribe" }, { "id", id }, { "ticks", true } };
            if (bodies != null) msg["bodies"] = bodies;
            if (region != null) msg["region"] = region;
            return Send(Encoding.UTF8.GetBytes(Json.Write(msg)), WebSocketMessageType.Text);
        }

        /// <summary>Stops tick frames.</summary>
        public Task Unsubscribe()
        {
            ulong id = (ulong)Interlocked.Increment(ref nextId);
            if (Wire == Wire.Protobuf) return Send(Protobuf.Subscribe(id, false, null, null), WebSocketMessageType.Binary);
            return Send(Encoding.UTF8.GetBytes("{\"type\":\"subscribe\",\"id\":" + id + ",\"ticks\":false}"), WebSocketMessageType.Text);
        }

        /// <summary>Closes the socket (Close 1000) and stops the loops.</summary>
        public async Task CloseAsync()
        {
            try
            {
                if (ws.State == WebSocketState.Open)
                {
                    var cts = new CancellationTokenSource(2000);
                    await ws.CloseOutputAsync(WebSocketCloseStatus.NormalClosure, "bye", cts.Token).ConfigureAwait(false);
                }
            }
            catch (Exception) { }
            stop.Cancel();
            try { if (pingTask != null) await pingTask.ConfigureAwait(false); } catch (Exception) { }
        }

        /// <summary>Aborts the socket.</summary>
        public void Dispose()
        {
            stop.Cancel();
            ws.Abort();
            ws.Dispose();
        }
    }
}
