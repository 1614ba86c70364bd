// The viewer's WebGPU renderer: the scene's exported WGSL (`lang=wgsl`) as it is, its `swell_vs`
// with a fragment shader appended here, the hulls, and the GPU probe through the exported
// `swell_probe_vs`/`swell_probe_fs` into two rgba32float targets. Used where WebGPU is available
// and the scene has no FFT layer (FFT layers reach the WebGL2 renderer as textures; the WGSL
// path does not read them yet). Same interface as the WebGL2 renderer in viewer.js:
// `frame({w, h, block, viewProj, eye, bodies})` and `probe(local, block) → height | null`.

const SEA_FS = `
struct ViewerFrame { eye: vec4<f32> }
@group(1) @binding(0) var<uniform> viewer_frame: ViewerFrame;

@fragment
fn viewer_sea_fs(v: SwellVertexOut) -> @location(0) vec4<f32> {
  let n = normalize(v.normal);
  let eye = viewer_frame.eye.xyz;
  let view = normalize(eye - v.position);
  let sun = normalize(vec3<f32>(0.4, 0.55, 0.25));
  let fres = 0.02 + 0.98 * pow(1.0 - max(dot(n, view), 0.0), 5.0);
  let deep = vec3<f32>(0.01, 0.10, 0.16);
  let shallow = vec3<f32>(0.05, 0.32, 0.38);
  let sky = vec3<f32>(0.55, 0.72, 0.86);
  let crest = clamp(v.position.y * 0.25 + 0.5, 0.0, 1.0);
  let water = mix(deep, shallow, crest) * (0.35 + 0.65 * max(dot(n, sun), 0.0));
  var c = mix(water, sky, fres);
  c = c + vec3<f32>(1.0, 0.95, 0.85) * pow(max(dot(reflect(-sun, n), view), 0.0), 180.0) * 1.5;
  let foam = 1.0 - smoothstep(0.0, 0.35, v.jacobian);
  c = mix(c, vec3<f32>(0.92, 0.95, 0.97), foam * 0.85);
  let fog = 1.0 - exp(-length(eye - v.position) * 0.0025);
  return vec4<f32>(mix(c, sky * 0.9, fog), 1.0);
}
`;

const BODY_WGSL = `
struct Body { view_proj: mat4x4<f32>, model: mat4x4<f32>, color: vec4<f32> }
@group(0) @binding(0) var<uniform> body: Body;
struct Out { @builtin(position) clip: vec4<f32>, @location(0) normal: vec3<f32> }
@vertex
fn vs(@location(0) pos: vec3<f32>, @location(1) normal: vec3<f32>) -> Out {
  let m = body.model;
  return Out(body.view_proj * m * vec4<f32>(pos, 1.0), mat3x3<f32>(m[0].xyz, m[1].xyz, m[2].xyz) * normal);
}
@fragment
fn fs(v: Out) -> @location(0) vec4<f32> {
  let l = 0.35 + 0.65 * max(dot(normalize(v.normal), normalize(vec3<f32>(0.4, 0.8, 0.3))), 0.0);
  return vec4<f32>(body.color.rgb * l, 1.0);
}
`;

// The adapter stays referenced for the page's life: Chromium's Dawn drops its instance when the
// adapter is collected, and the device's buffers then fail to map ("A valid external Instance
// reference no longer exists").
let adapter = null;

/** A WebGPU device with an adapter, or null where there is none (no WebGPU, or it is off). */
export async function webGpuDevice() {
  if (!globalThis.navigator?.gpu) return null;
  try {
    adapter = await navigator.gpu.requestAdapter();
    return adapter ? await adapter.requestDevice() : null;
  } catch {
    return null;
  }
}

/**
 * The renderer on `canvas` with `device`: `wgsl` is the scene's exported shader, `verts`/`idx`
 * the sea mesh (local x/z pairs, triangle indices), `box` the unit box (position, normal).
 */
export async function createWebGpuRenderer(canvas, device, { wgsl, verts, idx, box }) {
  const context = canvas.getContext('webgpu');
  const format = navigator.gpu.getPreferredCanvasFormat();
  context.configure({ device, format, alphaMode: 'opaque' });
  const errors = [];
  device.addEventListener?.('uncapturederror', (e) => errors.push(e.error?.message ?? String(e)));
  device.lost?.then((info) => { if (info.reason !== 'destroyed') errors.push(`device lost: ${info.message}`); });

  const seaModule = device.createShaderModule({ code: wgsl + SEA_FS });
  const info = await seaModule.getCompilationInfo?.();
  const bad = info?.messages?.filter((m) => m.type === 'error') ?? [];
  if (bad.length) throw new Error(`WGSL: ${bad.map((m) => `${m.lineNum}:${m.linePos} ${m.message}`).join('; ')}`);
  const depthFormat = 'depth24plus';
  const sea = device.createRenderPipeline({
    layout: 'auto',
    vertex: { module: seaModule, entryPoint: 'swell_vs', buffers: [{ arrayStride: 8, attributes: [{ shaderLocation: 0, offset: 0, format: 'float32x2' }] }] },
    fragment: { module: seaModule, entryPoint: 'viewer_sea_fs', targets: [{ format }] },
    primitive: { topology: 'triangle-list' },
    depthStencil: { format: depthFormat, depthWriteEnabled: true, depthCompare: 'less' },
  });
  const probePipe = device.createRenderPipeline({
    layout: 'auto',
    vertex: {
      module: seaModule, entryPoint: 'swell_probe_vs',
      buffers: [{ arrayStride: 16, attributes: [{ shaderLocation: 0, offset: 0, format: 'float32x2' }, { shaderLocation: 1, offset: 8, format: 'float32x2' }] }],
    },
    fragment: { module: seaModule, entryPoint: 'swell_probe_fs', targets: [{ format: 'rgba32float' }, { format: 'rgba32float' }] },
    primitive: { topology: 'point-list' },
  });
  const bodyModule = device.createShaderModule({ code: BODY_WGSL });
  const bodyPipe = device.createRenderPipeline({
    layout: 'auto',
    vertex: {
      module: bodyModule, entryPoint: 'vs',
      buffers: [{ arrayStride: 24, attributes: [{ shaderLocation: 0, offset: 0, format: 'float32x3' }, { shaderLocation: 1, offset: 12, format: 'float32x3' }] }],
    },
    fragment: { module: bodyModule, entryPoint: 'fs', targets: [{ format }] },
    primitive: { topology: 'triangle-list' },
    depthStencil: { format: depthFormat, depthWriteEnabled: true, depthCompare: 'less' },
  });

  const buffer = (data, usage) => {
    const b = device.createBuffer({ size: Math.ceil(data.byteLength / 4) * 4, usage: usage | GPUBufferUsage.COPY_DST });
    device.queue.writeBuffer(b, 0, data);
    return b;
  };
  const vbuf = buffer(verts, GPUBufferUsage.VERTEX);
  const ibuf = buffer(idx, GPUBufferUsage.INDEX);
  const boxBuf = buffer(box, GPUBufferUsage.VERTEX);
  let swellUbo = null; // sized on the first frame (the block's length is the scene's)
  const cameraUbo = device.createBuffer({ size: 64, usage: GPUBufferUsage.UNIFORM | GPUBufferUsage.COPY_DST });
  const frameUbo = device.createBuffer({ size: 16, usage: GPUBufferUsage.UNIFORM | GPUBufferUsage.COPY_DST });
  const frameGroup = device.createBindGroup({ layout: sea.getBindGroupLayout(1), entries: [{ binding: 0, resource: { buffer: frameUbo } }] });
  let seaGroup = null;
  const bodySlots = [];
  let depth = null;

  const frame = ({ w, h, block, viewProj, eye, bodies }) => {
    if (!swellUbo || swellUbo.size < block.byteLength) {
      swellUbo = device.createBuffer({ size: block.byteLength, usage: GPUBufferUsage.UNIFORM | GPUBufferUsage.COPY_DST });
      seaGroup = device.createBindGroup({
        layout: sea.getBindGroupLayout(0),
        entries: [{ binding: 0, resource: { buffer: swellUbo } }, { binding: 1, resource: { buffer: cameraUbo } }],
      });
    }
    if (!depth || depth.width !== w || depth.height !== h) {
      depth?.destroy();
      depth = device.createTexture({ size: [w, h], format: depthFormat, usage: GPUTextureUsage.RENDER_ATTACHMENT });
    }
    device.queue.writeBuffer(swellUbo, 0, block);
    device.queue.writeBuffer(cameraUbo, 0, new Float32Array(viewProj));
    device.queue.writeBuffer(frameUbo, 0, new Float32Array([eye[0], eye[1], eye[2], 0]));
    const enc = device.createCommandEncoder();
    const pass = enc.beginRenderPass({
      colorAttachments: [{ view: context.getCurrentTexture().createView(), clearValue: { r: 0.5, g: 0.66, b: 0.8, a: 1 }, loadOp: 'clear', storeOp: 'store' }],
      depthStencilAttachment: { view: depth.createView(), depthClearValue: 1, depthLoadOp: 'clear', depthStoreOp: 'store' },
    });
    pass.setPipeline(sea);
    pass.setBindGroup(0, seaGroup);
    pass.setBindGroup(1, frameGroup);
    pass.setVertexBuffer(0, vbuf);
    pass.setIndexBuffer(ibuf, 'uint32');
    pass.drawIndexed(idx.length);
    pass.setPipeline(bodyPipe);
    pass.setVertexBuffer(0, boxBuf);
    bodies.forEach((b, i) => {
      if (!bodySlots[i]) {
        const ubo = device.createBuffer({ size: 144, usage: GPUBufferUsage.UNIFORM | GPUBufferUsage.COPY_DST });
        bodySlots[i] = { ubo, group: device.createBindGroup({ layout: bodyPipe.getBindGroupLayout(0), entries: [{ binding: 0, resource: { buffer: ubo } }] }) };
      }
      const data = new Float32Array(36);
      data.set(viewProj, 0); data.set(b.model, 16); data.set([...b.color, 1], 32);
      device.queue.writeBuffer(bodySlots[i].ubo, 0, data);
      pass.setBindGroup(0, bodySlots[i].group);
      pass.draw(36);
    });
    pass.end();
    device.queue.submit([enc.finish()]);
    if (errors.length) throw new Error(`WebGPU: ${errors.splice(0).join('; ')}`);
  };

  // One probe point into 1×1 rgba32float targets; the second target's w is the height above
  // the point (swell_probe_fs), read back through a buffer (rows padded to 256 bytes).
  const probe = async (local, block) => {
    const ubo = buffer(block, GPUBufferUsage.UNIFORM);
    const group = device.createBindGroup({ layout: probePipe.getBindGroupLayout(0), entries: [{ binding: 0, resource: { buffer: ubo } }] });
    const targets = [0, 1].map(() => device.createTexture({ size: [1, 1], format: 'rgba32float', usage: GPUTextureUsage.RENDER_ATTACHMENT | GPUTextureUsage.COPY_SRC }));
    const vb = buffer(new Float32Array([local[0], local[1], 0, 0]), GPUBufferUsage.VERTEX);
    const out = device.createBuffer({ size: 256, usage: GPUBufferUsage.COPY_DST | GPUBufferUsage.MAP_READ });
    const enc = device.createCommandEncoder();
    const pass = enc.beginRenderPass({
      colorAttachments: targets.map((t) => ({ view: t.createView(), clearValue: { r: 0, g: 0, b: 0, a: 0 }, loadOp: 'clear', storeOp: 'store' })),
    });
    pass.setPipeline(probePipe);
    pass.setBindGroup(0, group);
    pass.setVertexBuffer(0, vb);
    pass.draw(1);
    pass.end();
    enc.copyTextureToBuffer({ texture: targets[1] }, { buffer: out, bytesPerRow: 256 }, [1, 1]);
    device.queue.submit([enc.finish()]);
    await out.mapAsync(GPUMapMode.READ);
    const height = new Float32Array(out.getMappedRange().slice(0))[3];
    out.unmap();
    [ubo, vb, out].forEach((b) => b.destroy());
    targets.forEach((t) => t.destroy());
    return height;
  };

  return { kind: 'webgpu', frame, probe };
}
