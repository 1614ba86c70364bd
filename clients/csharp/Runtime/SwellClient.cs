// The HTTP client: scenes, clocks, queries, shader includes, uniforms (JSON), with the server's
// error answers turned into SwellException (status, code, message, field).
using System;
using System.Collections.Generic;
using System.Globalization;
using System.Net.Http;
using System.Text;
using System.Threading.Tasks;

namespace Swell
{
    /// <summary>An error answer from the server (4xx/5xx), or a transport failure (Status 0).</summary>
    public sealed class SwellException : Exception
    {
        /// <summary>HTTP status (0: no answer).</summary>
        public readonly int Status;
        /// <summary>The server's error code (e.g. invalid_value).</summary>
        public readonly string Code;
        /// <summary>The field it names, if any.</summary>
        public readonly string Field;

        /// <summary>An error.</summary>
        public SwellException(int status, string code, string message, string field) : base(message)
        {
            Status = status;
            Code = code;
            Field = field;
        }
    }

    /// <summary>A scene clock's reading (GET/PUT …/clock, clock events).</summary>
    public struct ClockReading
    {
        /// <summary>Scene time at Unix, s.</summary>
        public double T;
        /// <summary>floor(t·tick_hz).</summary>
        public long Tick;
        /// <summary>Ticks per scene second.</summary>
        public double TickHz;
        /// <summary>Scene seconds per real second.</summary>
        public double Rate;
        /// <summary>Whether the clock is paused.</summary>
        public bool Paused;
        /// <summary>Unix time of the reading, s.</summary>
        public double Unix;
        /// <summary>One more after every admin change.</summary>
        public long Generation;

        /// <summary>The scene time at Unix time unixNow, following the clock on its own.</summary>
        public double At(double unixNow) { return T + (Paused ? 0 : Rate) * (unixNow - Unix); }

        internal static ClockReading From(object o)
        {
            return new ClockReading
            {
                T = Json.Num(o, "t"),
                Tick = (long)Json.Num(o, "tick"),
                TickHz = Json.Num(o, "tick_hz"),
                Rate = Json.Num(o, "rate"),
                Paused = Json.Bool(o, "paused", false),
                Unix = Json.Num(o, "unix"),
                Generation = (long)Json.Num(o, "generation", -1),
            };
        }
    }

    /// <summary>The HTTP API of a swell server.</summary>
    public sealed class SwellClient : IDisposable
    {
        readonly HttpClient http;
        readonly string baseUrl;
        /// <summary>The admin token (Bearer) for admin calls, or null.</summary>
        public string AdminToken;

        /// <summary>A client of baseUrl (e.g. http://127.0.0.1:8080).</summary>
        public SwellClient(string baseUrl, string adminToken = null, HttpMessageHandler handler = null)
        {
            this.baseUrl = baseUrl.TrimEnd('/');
            AdminToken = adminToken;
            http = handler == null ? new HttpClient() : new HttpClient(handler);
        }

        /// <summary>The ws(s):// URL of a scene's stream.</summary>
        public string StreamUrl(string scene)
        {
            string u = baseUrl.StartsWith("https://", StringComparison.Ordinal) ? "wss://" + baseUrl.Substring(8) : "ws://" + baseUrl.Substring(baseUrl.IndexOf("://", StringComparison.Ordinal) + 3);
            return u + "/v1/scenes/" + CheckId(scene) + "/stream";
        }

        static string CheckId(string id)
        {
            if (string.IsNullOrEmpty(id) || id.Length > 64) throw new ArgumentException("scene id must match [a-z0-9-]{1,64}", "scene");
            foreach (char c in id)
                if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-')) throw new ArgumentException("scene id must match [a-z0-9-]{1,64}", "scene");
            return id;
        }

        /// <summary>Sends a request; the body text of a 2xx answer.</summary>
        /// <exception cref="SwellException">An error answer or no answer.</exception>
        public async Task<string> RequestText(HttpMethod method, string path, string jsonBody = null, bool admin = false)
        {
            var req = new HttpRequestMessage(method, baseUrl + path);
            if (jsonBody != null) req.Content = new StringContent(jsonBody, Encoding.UTF8, "application/json");
            if (admin && AdminToken != null) req.Headers.TryAddWithoutValidation("Authorization", "Bearer " + AdminToken);
            HttpResponseMessage resp;
            try { resp = await http.SendAsync(req).ConfigureAwait(false); }
            catch (Exception e) { throw new SwellException(0, "transport", method + " " + path + ": " + e.Message, null); }
            string text = await resp.Content.ReadAsStringAsync().ConfigureAwait(false);
            int status = (int)resp.StatusCode;
            if (status >= 200 && status < 300) return text;
            throw ErrorOf(status, text);
        }

        /// <summary>
        /// GET /v1/scenes/{id}/spectrum?layer=N: an FFT layer's exported spectrum
        /// (`swell-spectrum/1`), for <see cref="FftSpectrum.Parse"/> and <see cref="FftLayer"/>.
        /// </summary>
        /// <exception cref="SwellException">An error answer (not an FFT layer: 400) or no answer.</exception>
        public async Task<byte[]> Spectrum(string id, int layer)
        {
            string path = "/v1/scenes/" + CheckId(id) + "/spectrum?layer=" + layer.ToString(System.Globalization.CultureInfo.InvariantCulture);
            HttpResponseMessage resp;
            try { resp = await http.GetAsync(baseUrl + path).ConfigureAwait(false); }
            catch (Exception e) { throw new SwellException(0, "transport", "GET " + path + ": " + e.Message, null); }
            byte[] bytes = await resp.Content.ReadAsByteArrayAsync().ConfigureAwait(false);
            int status = (int)resp.StatusCode;
            if (status >= 200 && status < 300) return bytes;
            throw ErrorOf(status, Encoding.UTF8.GetString(bytes));
        }

        /// <summary>The exception for an error answer: its JSON error's code, message and field, or the status and text.</summary>
        static SwellException ErrorOf(int status, string text)
        {
            string code = "http_" + status, message = text, field = null;
            try
            {
                var err = Json.Get(Json.Parse(text), "error");
                if (err != null) { code = Json.Str(err, "code"); message = Json.Str(err, "message"); field = Json.Str(err, "field"); }
            }
            catch (FormatException) { }
            return new SwellException(status, code, message, field);
        }

        /// <summary>Sends a request; the parsed JSON answer.</summary>
        public async Task<object> RequestJson(HttpMethod method, string path, object body = null, bool admin = false)
        {
            string text = await RequestText(method, path, body == null ? null : Json.Write(body), admin).ConfigureAwait(false);
            return text.Length == 0 ? null : Json.Parse(text);
        }

        /// <summary>GET /v1/scenes.</summary>
        public Task<object> Scenes() { return RequestJson(HttpMethod.Get, "/v1/scenes"); }

        /// <summary>GET /v1/scenes/{id}: spec, derived (every built wave), clock.</summary>
        public Task<object> Scene(string id) { return RequestJson(HttpMethod.Get, "/v1/scenes/" + CheckId(id)); }

        /// <summary>PUT /v1/scenes/{id} (admin).</summary>
        public Task<object> PutScene(string id, object spec) { return RequestJson(HttpMethod.Put, "/v1/scenes/" + CheckId(id), spec, true); }

        /// <summary>DELETE /v1/scenes/{id} (admin).</summary>
        public Task<string> DeleteScene(string id) { return RequestText(HttpMethod.Delete, "/v1/scenes/" + CheckId(id), null, true); }

        /// <summary>GET /v1/scenes/{id}/clock.</summary>
        public async Task<ClockReading> Clock(string id)
        {
            return ClockReading.From(await RequestJson(HttpMethod.Get, "/v1/scenes/" + CheckId(id) + "/clock").ConfigureAwait(false));
        }

        /// <summary>PUT /v1/scenes/{id}/clock (admin): seek, rate and/or pause (null: unchanged).</summary>
        public async Task<ClockReading> SetClock(string id, double? t = null, double? rate = null, bool? paused = null)
        {
            var body = new Dictionary<string, object>();
            if (t.HasValue) body["t"] = t.Value;
            if (rate.HasValue) body["rate"] = rate.Value;
            if (paused.HasValue) body["paused"] = paused.Value;
            return ClockReading.From(await RequestJson(HttpMethod.Put, "/v1/scenes/" + CheckId(id) + "/clock", body, true).ConfigureAwait(false));
        }

        /// <summary>POST /v1/scenes/{id}/sample: points [[x, z], …] at t (null: now); the JSON answer.</summary>
        public Task<object> Sample(string id, IList<double[]> points, double? t = null, IList<string> fields = null)
        {
            var body = new Dictionary<string, object>();
            if (t.HasValue) body["t"] = t.Value;
            body["points"] = points;
            if (fields != null) body["fields"] = fields;
            return RequestJson(HttpMethod.Post, "/v1/scenes/" + CheckId(id) + "/sample", body);
        }

        /// <summary>GET /v1/scenes/{id}/uniforms at t and origin: {t, origin, waves, phases, block, rings_dropped}.</summary>
        public Task<object> Uniforms(string id, double t, double ox = 0, double oz = 0)
        {
            // Escaped: a number's "R" form may hold a '+' (1E+20), which a query reads as a space.
            return RequestJson(HttpMethod.Get, "/v1/scenes/" + CheckId(id) + "/uniforms?t=" + Uri.EscapeDataString(Json.Number(t))
                + "&origin=" + Uri.EscapeDataString(Json.Number(ox) + "," + Json.Number(oz)));
        }

        /// <summary>GET /v1/scenes/{id}/shader?lang=: the generated shader text (hlsl_include for Unity, gdshaderinc for Godot).</summary>
        public Task<string> Shader(string id, string lang)
        {
            return RequestText(HttpMethod.Get, "/v1/scenes/" + CheckId(id) + "/shader?lang=" + Uri.EscapeDataString(lang));
        }

        /// <summary>POST /v1/scenes/{id}/bodies (game/admin): spawns a body; its description.</summary>
        public Task<object> SpawnBody(string id, object spec)
        {
            return RequestJson(HttpMethod.Post, "/v1/scenes/" + CheckId(id) + "/bodies", spec, true);
        }

        /// <summary>Closes the connection pool.</summary>
        public void Dispose() { http.Dispose(); }
    }
}
