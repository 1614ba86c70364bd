// The P/Invoke option (Runtime/SwellNative.cs) against the golden vectors, every case and every
// field bit for bit, FFT scenes included (which the managed port does not evaluate); the managed
// port and the native model agree to the bit where both apply; errors come back as exceptions
// with the library's code and message.
using System;
using System.IO;
using System.Linq;

namespace Swell.Tests
{
    static class NativeTests
    {
        internal static void Run(string vectors)
        {
            object doc = Json.Parse(File.ReadAllText(Path.Combine(vectors, "surface_v1.json")));
            Runner.T("native: model version matches the vectors", () =>
                Runner.Equal(Json.Num(doc, "model_version"), (double)NativeSurface.ModelVersion, "model_version"));
            foreach (var c in Json.List(doc, "cases"))
            {
                string name = Json.Str(c, "name");
                Runner.T("native golden " + name + ": every field bit for bit", () =>
                {
                    using (var s = new NativeSurface(Json.Write(Json.Get(c, "spec"))))
                    {
                        int n = 0;
                        foreach (var e in Json.List(c, "expected"))
                        {
                            var pt = Json.Nums(Json.Get(e, "point"));
                            double t = Json.Num(e, "t");
                            var q = s.Sample(t, new[] { pt[0], pt[1] }, NativeFields.All)[0];
                            var bits = Json.Get(e, "bits");
                            string where = name + " t=" + t + " point=" + pt[0] + "," + pt[1];
                            Runner.Equal(Json.Str(bits, "height"), SwellMath.BitsHex(q.Height), where + " height");
                            var nb = Json.List(bits, "normal");
                            var db = Json.List(bits, "displacement");
                            var normal = new[] { q.NormalX, q.NormalY, q.NormalZ };
                            var disp = new[] { q.DisplacementX, q.DisplacementY, q.DisplacementZ };
                            for (int k = 0; k < 3; k++)
                            {
                                Runner.Equal((string)nb[k], SwellMath.BitsHex(normal[k]), where + " normal[" + k + "]");
                                Runner.Equal((string)db[k], SwellMath.BitsHex(disp[k]), where + " displacement[" + k + "]");
                            }
                            Runner.Equal(Json.Str(bits, "jacobian"), SwellMath.BitsHex(q.Jacobian), where + " jacobian");
                            Runner.Equal(Json.Str(bits, "residual"), SwellMath.BitsHex(q.Residual), where + " residual");
                            Runner.Equal(Json.Bool(bits, "folded", false), q.Folded == 1, where + " folded");
                            Runner.Equal(SwellMath.BitsHex(q.Height), SwellMath.BitsHex(s.Height(t, pt[0], pt[1])), where + " Height()");
                            n++;
                        }
                        Runner.Assert(n > 0, name + ": no expected points");
                    }
                });
            }

            Runner.T("native and managed give the same bits on a Gerstner scene", () =>
            {
                var c = Json.List(doc, "cases").First(k => Json.Str(k, "name") == "steep_gerstner_s095");
                var spec = Json.Get(c, "spec");
                var managed = Surface.FromSpec(spec);
                using (var native = new NativeSurface(Json.Write(spec)))
                {
                    var xz = new double[2 * 400];
                    for (int i = 0; i < 400; i++) { xz[2 * i] = i * 0.731 - 140; xz[2 * i + 1] = (i % 23) * 3.17 - 30; }
                    foreach (double t in new[] { 0.0, 17.25, 86400.5 })
                    {
                        var got = native.Sample(t, xz, NativeFields.All);
                        for (int i = 0; i < 400; i++)
                        {
                            var m = managed.Query(xz[2 * i], xz[2 * i + 1], t);
                            Runner.Equal(SwellMath.BitsHex(m.Height), SwellMath.BitsHex(got[i].Height), "height at " + i + " t=" + t);
                            Runner.Equal(SwellMath.BitsHex(m.Normal[1]), SwellMath.BitsHex(got[i].NormalY), "normal.y at " + i + " t=" + t);
                        }
                    }
                }
            });

            Runner.T("native errors: bad JSON and a rejected spec throw with code and message", () =>
            {
                try { new NativeSurface("{not json").Dispose(); throw new Exception("bad JSON was accepted"); }
                catch (SwellNativeException e) { Runner.Equal(2, e.Code, "bad JSON code " + e.Message); }
                try
                {
                    new NativeSurface("{\"layers\": [{\"kind\": \"sine\", \"waves\": [{\"amplitude\": -1, \"wavelength\": 5, \"direction\": [1, 0]}]}]}").Dispose();
                    throw new Exception("a negative amplitude was accepted");
                }
                catch (SwellNativeException e)
                {
                    Runner.Equal(3, e.Code, "invalid spec code");
                    Runner.Assert(e.Message.Contains("amplitude"), "the message names the field: " + e.Message);
                }
                using (var s = new NativeSurface("{\"layers\": [{\"kind\": \"sine\", \"waves\": [{\"amplitude\": 1, \"wavelength\": 5, \"direction\": [1, 0]}]}]}"))
                {
                    try { s.Height(double.NaN, 0, 0); throw new Exception("NaN t was accepted"); }
                    catch (SwellNativeException e) { Runner.Equal(4, e.Code, "invalid argument code"); }
                }
            });
        }
    }
}
