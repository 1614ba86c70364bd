extends Node3D
## The scene's sea, drawn through its Godot shader include (GET …/shader?lang=gdshaderinc), and
## optionally a boat that follows one of its bodies.
##
## On _ready it makes a SwellClient and a SwellSession as children, fetches the scene and its
## include, and draws a subdivided plane at this node's position with a spatial shader that
## #includes it (the text is pasted in: a runtime-fetched include has no resource path). Every
## frame it sets the include's uniforms for server_time() at this node's x/z (the render
## origin; keep the node unrotated and unscaled, and move it with the camera, so that the f32
## local coordinates stay small):
## - sine and Gerstner scenes: computed here in f64 (swell_surface.gd), the server's bits;
## - scenes with a particle layer (harbour): the server's block, GET …/uniforms, one request in
##   flight at a time, asked for the time the answer will be drawn at;
## - FFT layers: their grid offset is set, but their result textures (swell_fftN_a/b) are not:
##   those come from GPU compute passes this addon does not run, so an FFT layer draws flat.

const SwellClient := preload("swell_client.gd")
const SwellSession := preload("swell_session.gd")
const SwellSurface := preload("swell_surface.gd")
const BodyInterpolator := preload("body_interpolator.gd")

## Emitted once the sea is drawn and the clock synced.
signal ready_to_draw

@export var server_url: String = "http://127.0.0.1:8080"
@export var scene_id: String = "calm"
## Side of the drawn square, m, and its subdivisions per side.
@export var size: float = 200.0
@export var subdivisions: int = 200
## A node that follows body `body_id` (-1: none), interpolated `interpolation_delay` s behind.
@export var boat: Node3D
@export var body_id: int = -1
@export var interpolation_delay: float = 0.1
@export var water_color: Color = Color(0.02, 0.13, 0.2)

var client
var session
var surface
var interpolator = BodyInterpolator.new()
var material: ShaderMaterial
var mesh_instance: MeshInstance3D
## The include's vec4 uniforms in declaration order: [[name, vec4 count, is_array], ...].
var uniform_layout: Array = []
## The last block set (f32), and the scene time it was for.
var last_block := PackedFloat32Array()
var last_time: float = NAN
var _fetching := false


func _ready() -> void:
	client = SwellClient.new()
	client.base_url = server_url
	add_child(client)
	session = SwellSession.new()
	session.url = client.stream_url(scene_id)
	session.interpolator = interpolator
	interpolator.delay = interpolation_delay
	add_child(session)
	var scene = await client.scene(scene_id)
	var inc = await client.shader_include(scene_id)
	if scene == null or inc == null:
		push_error("swell: cannot load scene %s from %s: %s" % [scene_id, server_url, client.last_error])
		return
	surface = SwellSurface.new(scene)
	build_material(inc)
	if not await session.open():
		push_error("swell: cannot open %s" % session.url)
		return
	if body_id >= 0:
		session.subscribe([body_id])
	ready_to_draw.emit()


## Builds the sea's material and mesh from the include's text.
func build_material(include_text: String) -> void:
	uniform_layout = parse_uniforms(include_text)
	var shader := Shader.new()
	shader.code = "shader_type spatial;\n" + include_text + """
uniform vec3 swell_water_color = vec3(0.02, 0.13, 0.2);
void vertex() {
	SwellSample s = swell_sample(VERTEX.xz);
	VERTEX += s.displacement;
	NORMAL = swell_normal(s);
}
void fragment() {
	ALBEDO = swell_water_color;
	ROUGHNESS = 0.15;
	METALLIC = 0.0;
}
"""
	material = ShaderMaterial.new()
	material.shader = shader
	material.set_shader_parameter("swell_water_color", Vector3(water_color.r, water_color.g, water_color.b))
	var plane := PlaneMesh.new()
	plane.size = Vector2(size, size)
	plane.subdivide_width = subdivisions
	plane.subdivide_depth = subdivisions
	mesh_instance = MeshInstance3D.new()
	mesh_instance.mesh = plane
	mesh_instance.material_override = material
	# Displaced vertices leave the flat plane's bounds: keep it from being culled.
	mesh_instance.extra_cull_margin = 16.0
	add_child(mesh_instance)


## The include's `uniform vec4 swell_u_*` declarations, in order: [name, vec4 count, is_array].
static func parse_uniforms(include_text: String) -> Array:
	var re := RegEx.new()
	re.compile("(?m)^uniform\\s+vec4\\s+(swell_u_\\w+)\\s*(\\[(\\d+)\\])?\\s*;")
	var out: Array = []
	for m in re.search_all(include_text):
		var n := 1 if m.get_string(3) == "" else int(m.get_string(3))
		out.append([m.get_string(1), n, m.get_string(3) != ""])
	return out


## Sets the include's uniforms from a block (4 floats per vec4, in declaration order).
func set_block(block: PackedFloat32Array) -> void:
	var k := 0
	for u in uniform_layout:
		var vs := PackedVector4Array()
		for i in u[1]:
			var b: int = k + 4 * i
			if b + 3 < block.size():
				vs.append(Vector4(block[b], block[b + 1], block[b + 2], block[b + 3]))
			else:
				vs.append(Vector4.ZERO)
		k += 4 * u[1]
		material.set_shader_parameter(u[0], vs if u[2] else vs[0])
	last_block = block


func _process(_delta: float) -> void:
	if material == null or session == null or not session.synced():
		return
	var t: float = session.server_time()
	var o := global_position
	if surface.local:
		set_block(surface.uniforms(t, o.x, o.z).block)
		last_time = t
	elif not _fetching:
		_fetch_block(o.x, o.z)
	if boat != null and body_id >= 0:
		var s = interpolator.at(t).get(body_id)
		if s != null:
			boat.global_position = s.position
			boat.quaternion = s.rotation


# Particle scenes: the server's block for the time the answer will be drawn at (now plus the
# last round trip), one request in flight.
var _fetch_rtt := 0.05
func _fetch_block(ox: float, oz: float) -> void:
	_fetching = true
	var sent: float = session.now.call()
	var t: float = session.server_time() + _fetch_rtt
	var u = await client.uniforms(scene_id, t, Vector2.ZERO, [ox, oz])
	_fetch_rtt = session.now.call() - sent
	_fetching = false
	if u != null:
		set_block(PackedFloat32Array(u.block))
		last_time = t
