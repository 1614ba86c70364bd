// Unity sample: fetches a scene and its HLSL include, keeps a WebSocket session's clock, and sets
// the shader's uniform block every frame from phases computed on the CPU in double precision
// (the shader adds only a small local term: see docs/clients.md). Put the include text in your
// material's shader (it is logged and exposed as HlslInclude; Unity cannot compile shader source
// at run time), assign the material, and set SceneId.
//
// The uniform block is the `SwellUniforms` cbuffer of the include: `swell_u_phases` (float4s),
// then, per FFT layer, `swell_u_fft` (its grid offset). Surfaces with particle layers: fetch GET …/uniforms instead (see the
// package README).
#if UNITY_5_3_OR_NEWER
using System.Threading.Tasks;
using UnityEngine;

namespace Swell.Samples
{
    public sealed class SwellOcean : MonoBehaviour
    {
        public string ServerUrl = "http://127.0.0.1:8080";
        public string SceneId = "calm";
        public Material Material;
        /// <summary>World position (x, z) of the mesh origin: the shader's local term is relative to it.</summary>
        public Vector2 RenderOrigin;
        [TextArea] public string HlslInclude;

        SwellClient client;
        SwellSession session;
        Surface surface;
        Vector4[] phases = new Vector4[0], ffts = new Vector4[0];

        async void Start()
        {
            client = new SwellClient(ServerUrl);
            var detail = await client.Scene(SceneId);
            surface = Surface.FromDerived(Json.Get(detail, "derived"));
            HlslInclude = await client.Shader(SceneId, "hlsl_include");
            session = new SwellSession(client.StreamUrl(SceneId), Wire.Protobuf);
            await session.ConnectAsync();
        }

        void Update()
        {
            if (session == null || surface == null || Material == null || !session.Clock.Synced) return;
            // Scene time from the synced clock; phases in f64 on the CPU, to f32 for the GPU.
            var u = surface.Uniforms(session.ServerTime(), RenderOrigin.x, RenderOrigin.y);
            Fill(ref phases, u.Block, 0, u.PhaseSlots / 4);
            Material.SetVectorArray("swell_u_phases", phases);
            int nfft = (u.Block.Length - u.PhaseSlots) / 4;
            if (nfft > 0)
            {
                Fill(ref ffts, u.Block, u.PhaseSlots, nfft);
                Material.SetVectorArray("swell_u_fft", ffts);
            }
        }

        static void Fill(ref Vector4[] v, float[] block, int start, int n)
        {
            if (v.Length != n) v = new Vector4[n];
            for (int i = 0; i < n; i++)
            {
                int k = start + 4 * i;
                v[i] = new Vector4(block[k], block[k + 1], block[k + 2], block[k + 3]);
            }
        }

        void OnDestroy()
        {
            if (session != null) session.Dispose();
            if (client != null) client.Dispose();
        }

        /// <summary>The shared session, for other components (SwellFollowBody).</summary>
        public SwellSession Session { get { return session; } }
    }
}
#endif
