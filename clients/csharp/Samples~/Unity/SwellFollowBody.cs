// Unity sample: makes this transform follow a floating body, rendered 0.1 s behind the synced
// server time between the two tick frames around it (the JS client's interpolation rules).
// Swell is right-handed (y up); Unity is left-handed: z is mirrored here.
#if UNITY_5_3_OR_NEWER
using UnityEngine;

namespace Swell.Samples
{
    public sealed class SwellFollowBody : MonoBehaviour
    {
        public SwellOcean Ocean;
        public long BodyId;
        readonly BodyInterpolator interpolator = new BodyInterpolator();
        bool subscribed;

        async void Update()
        {
            var s = Ocean != null ? Ocean.Session : null;
            if (s == null || !s.Clock.Synced) return;
            if (!subscribed)
            {
                subscribed = true;
                s.Interpolator = interpolator;
                await s.Subscribe(new[] { (ulong)BodyId });
                return;
            }
            InterpolatedBody b;
            if (!interpolator.At(s.ServerTime()).TryGetValue((ulong)BodyId, out b)) return;
            transform.position = new Vector3((float)b.Position[0], (float)b.Position[1], -(float)b.Position[2]);
            transform.rotation = new Quaternion(-(float)b.Rotation[0], -(float)b.Rotation[1], (float)b.Rotation[2], (float)b.Rotation[3]);
        }
    }
}
#endif
