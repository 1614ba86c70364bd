// Godot 4 .NET sample: a Node3D that syncs to a scene's clock, sets the uniforms of a material
// using the scene's `.gdshaderinc` (GET …/shader?lang=gdshaderinc) every frame, and moves an
// optional child to a body. Copy into a Godot project (with the package's Runtime/*.cs) and
// define GODOT (Godot's C# projects do).
#if GODOT
using Godot;
using Swell;

public partial class SwellOceanNode : Node3D
{
    [Export] public string ServerUrl = "http://127.0.0.1:8080";
    [Export] public string SceneId = "calm";
    [Export] public ShaderMaterial Material;
    [Export] public Node3D Boat;
    [Export] public long BodyId = -1;

    SwellClient client;
    SwellSession session;
    Surface surface;
    readonly BodyInterpolator interpolator = new BodyInterpolator();

    public override async void _Ready()
    {
        client = new SwellClient(ServerUrl);
        surface = Surface.FromDerived(Json.Get(await client.Scene(SceneId), "derived"));
        session = new SwellSession(client.StreamUrl(SceneId), Wire.Protobuf) { Interpolator = interpolator };
        await session.ConnectAsync();
        if (BodyId >= 0) await session.Subscribe(new[] { (ulong)BodyId });
    }

    public override void _Process(double delta)
    {
        if (session == null || !session.Clock.Synced) return;
        double t = session.ServerTime();
        var o = GlobalPosition;
        var u = surface.Uniforms(t, o.X, o.Z);
        var phases = new Vector4[u.PhaseSlots / 4];
        for (int i = 0; i < phases.Length; i++) phases[i] = new Vector4(u.Block[4 * i], u.Block[4 * i + 1], u.Block[4 * i + 2], u.Block[4 * i + 3]);
        Material?.SetShaderParameter("swell_u_phases", phases);
        var ffts = new Vector4[(u.Block.Length - u.PhaseSlots) / 4];
        for (int i = 0; i < ffts.Length; i++) { int k = u.PhaseSlots + 4 * i; ffts[i] = new Vector4(u.Block[k], u.Block[k + 1], 0, 0); }
        if (ffts.Length > 0) Material?.SetShaderParameter("swell_u_fft", ffts);
        InterpolatedBody b;
        if (Boat != null && BodyId >= 0 && interpolator.At(t).TryGetValue((ulong)BodyId, out b))
        {
            // Godot is right-handed, y up, like Swell.
            Boat.GlobalPosition = new Vector3((float)b.Position[0], (float)b.Position[1], (float)b.Position[2]);
            Boat.Quaternion = new Quaternion((float)b.Rotation[0], (float)b.Rotation[1], (float)b.Rotation[2], (float)b.Rotation[3]);
        }
    }

    public override void _ExitTree()
    {
        session?.Dispose();
        client?.Dispose();
    }
}
#endif
