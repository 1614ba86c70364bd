// Types of the swell-client package (hand-written beside the JSDoc'd ES modules in src/).

export type Vec2 = [number, number];
export type Vec3 = [number, number, number];
export type Quat = [number, number, number, number];
export type FieldName = 'height' | 'normal' | 'displacement' | 'jacobian' | 'residual';

export interface Accuracy {
  method?: 'newton' | 'fixed_point';
  iterations?: number;
  tolerance?: number;
  filter?: 'nearest' | 'bilinear' | 'bicubic';
  precision?: 'f64' | 'f32';
  time?: 'grid' | 'exact';
}
export interface SampleRequest { t?: number; origin?: Vec2; points: Vec2[]; fields?: FieldName[]; accuracy?: Accuracy }
export interface SampleResponse {
  t: number; height?: number[]; normal?: Vec3[]; displacement?: Vec3[];
  jacobian?: number[]; folded?: boolean[]; residual?: number[];
}
export interface BodyFootprint { position: Vec2; yaw?: number; length: number; beam: number; probes?: Vec2[] }
export interface OrientationRequest { t?: number; bodies: BodyFootprint[] }
export interface BodyOrientation { heave: number; rotation: Quat; normal: Vec3; pitch: number; roll: number }
export interface OrientationResponse { t: number; bodies: BodyOrientation[] }
export interface BodyState {
  id: number; position: Vec3; rotation: Quat; velocity: Vec3; angular_velocity: Vec3;
  submerged: number; quarantined: boolean;
}
export interface Impact { t: number; position: Vec2; strength: number; radius: number }
/** An impact as tick frames and GET …/impacts carry it: `tick`, the first tick at or after
 * `t`. `body_tick`, in a tick frame, for an API impact on a scene with bodies: the scene tick
 * the server's bodies feel it from (the POST answer's and `bodies().felt_impacts`'), which a
 * client replaying the bodies feels it at; absent for impacts the bodies made (splashes, wakes:
 * derive them), on scenes without bodies, and in GET …/impacts. */
export interface ImpactEvent extends Impact { tick: number; body_tick?: number }
/** An API impact the scene's bodies feel, with the scene tick they feel it from. */
export interface FeltImpact extends Impact { body_tick?: number }
/** `anchor_tick`: the scene's body world's anchor (absent while the scene has no bodies); a change means a clock
 * jump re-anchored it (rebuild a replayed world from `bodies()`). */
export interface TickFrame { tick: number; t: number; bodies: BodyState[]; impacts?: ImpactEvent[]; anchor_tick?: number }
export interface HullExtent { kind: 'box' | 'cells'; length: number; beam: number; height: number; center: Vec3 }
/** A body input as the server's world holds it (scene ticks). */
export interface InputSpan { force: Vec3; torque: Vec3; from_tick: number; ticks: number }
/** A body a re-anchor carried into the current world: its state at `anchor_tick`, and its
 * inputs that were still running, each acting from `anchor_tick` for the ticks it had left. */
export interface CarriedBody { state: BodyState; inputs: InputSpan[] }
/** GET …/bodies and …/bodies/{id}: the state plus what a spawn fixed (mass, hull extent), the
 * tick it was spawned at (absent for bodies restored from older records) and, after a
 * re-anchor, what it starts the current world from. */
export interface BodyDescription extends BodyState { mass: number; hull: HullExtent; spawn_tick?: number; carried?: CarriedBody }
/** POST …/bodies answer: the state at rest, the tick the spawn applied at, the world's anchor. */
export interface SpawnedBody extends BodyState { spawn_tick: number; anchor_tick: number }
export interface Wave { amplitude: number; wavenumber: number; omega: number; direction: Vec2; phase: number; steepness: number }
export interface Spectrum { header: Record<string, any>; n: number; records: Float64Array }

export class ArgumentError extends TypeError { field: string; constructor(field: string, message: string) }
export class SwellError extends Error { status: number; code: string; serverMessage: string; field?: string }
export class TransportError extends Error {}

export interface ClientOptions { wire?: 'json' | 'protobuf'; fetch?: typeof fetch; adminToken?: string }
export class SwellClient {
  constructor(baseUrl: string, options?: ClientOptions);
  streamUrl(scene: string): string;
  scenes(): Promise<{ scenes: { id: string; description: string; layers: string[]; tick_hz: number }[] }>;
  scene(id: string): Promise<any>;
  clock(id: string): Promise<ClockReading>;
  setClock(id: string, update: { t?: number; rate?: number; paused?: boolean }): Promise<ClockReading>;
  height(id: string, x: number, z: number, opts?: { t?: number }): Promise<{ t: number; height: number }>;
  sample(id: string, req: SampleRequest, opts?: { wire?: 'json' | 'protobuf' }): Promise<SampleResponse>;
  orientation(id: string, req: OrientationRequest, opts?: { wire?: 'json' | 'protobuf' }): Promise<OrientationResponse>;
  shader(id: string, lang: 'wgsl' | 'glsl' | 'glsl_es' | 'hlsl' | 'msl' | 'hlsl_include' | 'gdshaderinc', opts?: { entry?: 'swell_vs' | 'swell_probe_vs' | 'swell_probe_fs' | 'swell_fft_vs' | 'swell_fft_evolve' | 'swell_fft_butterfly' | 'swell_fft_evolve_cs' | 'swell_fft_butterfly_cs'; layer?: number }):
    Promise<{ text: string; modelVersion: number; specHash: string; etag: string }>;
  uniforms(id: string, opts?: { t?: number; origin?: Vec2 }): Promise<{ t: number; origin: Vec2; waves: number; phases: number[]; block: number[]; rings_dropped: number }>;
  impacts(id: string, opts?: { t?: number }): Promise<{ t: number; impacts: ImpactEvent[] }>;
  addImpact(id: string, impact: { position: Vec2; t?: number; strength: number; radius: number }): Promise<{ tick: number; t: number; body_tick?: number }>;
  spectrum(id: string, layer: number): Promise<Spectrum>;
  bodies(id: string): Promise<{ tick: number; t: number; anchor_tick?: number; bodies: BodyDescription[]; felt_impacts?: FeltImpact[] }>;
  body(id: string, bid: number): Promise<BodyDescription & { tick: number; anchor_tick: number }>;
  spawnBody(id: string, spec: object): Promise<SpawnedBody>;
  putScene(id: string, spec: object): Promise<any>;
  deleteScene(id: string): Promise<void>;
}

/** A scene clock's reading: `t` at Unix time `unix`; `generation` counts admin changes. */
export interface ClockReading { t: number; tick: number; tick_hz: number; rate: number; paused: boolean; unix: number; generation: number }
/** A pong: the client's time echoed, the scene clock when answered, and the clock's state. */
export interface Pong { client_time: number; scene_time: number; tick: number; rate: number; paused: boolean; generation: number }

export class ClockSync {
  constructor(options?: { window?: number; best?: number }, clock?: { rate?: number; paused?: boolean; generation?: number | null });
  offset: number; drift: number; rtt: number; minRtt: number; readonly synced: boolean;
  rate: number; paused: boolean; generation: number | null; readonly slope: number;
  provisional: { at: number; t: number } | null;
  add(sent: number, received: number, sceneTime: number): void;
  sceneTime(clientTime: number): number;
}

export interface SessionOptions {
  WebSocket?: any; pingInterval?: number; syncPings?: number; resyncPings?: number; requestTimeout?: number;
  onClock?: (ev: ClockReading) => void;
  backoff?: { initial?: number; max?: number; factor?: number };
  onTick?: (frame: TickFrame) => void; onOpen?: () => void;
  /** The socket closed: code 4404 (`SCENE_GONE`) means the scene was deleted; no reconnect then. */
  onClose?: (ev: { code: number | string; reason: string }) => void;
  /** An error the server sent that answers no request of this session (e.g. the scene was deleted). */
  onError?: (err: SwellError) => void;
  interpolator?: BodyInterpolator; now?: () => number; clock?: { window?: number; best?: number };
}
/** The Close code of a session whose scene was deleted. */
export const SCENE_GONE: 4404;
export class SwellSession {
  constructor(url: string, options?: SessionOptions);
  connect(): Promise<this>;
  opened(): Promise<void>;
  ping(): Promise<Pong>;
  syncNow(n?: number): Promise<ClockSync>;
  serverTime(): number;
  clockStats(): { offset: number; drift: number; rtt: number; minRtt: number; rate: number; paused: boolean; generation: number | null };
  sample(req: SampleRequest): Promise<SampleResponse>;
  orientation(req: OrientationRequest): Promise<OrientationResponse>;
  subscribe(interest?: { bodies?: number[]; region?: [number, number, number, number] }): void;
  unsubscribe(): void;
  close(): void;
  readonly reconnects: number;
  /** Resolves when the clock re-sync after the latest reconnect is done (null before one). */
  readonly resyncing: Promise<void> | null;
  readonly lastTick: TickFrame | null;
  readonly lastClock: ClockReading | undefined;
}

export interface InterpolatedBody { id: number; t: number; tick: number; position: Vec3; rotation: Quat; mode: 'interpolated' | 'extrapolated' | 'held' }
export class BodyInterpolator {
  constructor(options?: { delay?: number; capacity?: number; maxExtrapolation?: number });
  delay: number;
  push(frame: TickFrame): void;
  frameAt(tick: number): { tick: number; t: number; bodies: BodyState[]; byId: Map<number, BodyState> } | null;
  at(serverTime: number): Map<number, InterpolatedBody>;
  sample(t: number): Map<number, InterpolatedBody>;
}

export interface SurfaceSample { d: Vec3; dx: Vec3; dz: Vec3 }
export interface PointResult { height: number; normal: Vec3; displacement: Vec3; jacobian: number; folded: boolean; residual: number }
export interface Inversion { method: 'newton' | 'fixed_point'; iterations: number; tolerance: number }
export const DEFAULT_INVERSION: Inversion;
export interface SurfaceOptions { fft?: (FftLayer | null | undefined)[]; impacts?: ImpactSet; gravity?: number; depth?: number | null }
export interface LiveRing { ring: Ring; state: RingState; invR2: number }
export class Surface {
  constructor(layers: { kind: string; waves?: Wave[] }[], options?: SurfaceOptions);
  static fromDerived(derived: { layers: any[]; gravity?: number; depth?: number | null }, options?: SurfaceOptions): Surface;
  static fromSpec(spec: { gravity?: number; depth?: number | null; layers: any[] }): Surface;
  readonly horizontal: boolean;
  /** The scene's impacts: rings ripple on the first particle layer. */
  readonly impacts: ImpactSet;
  readonly impactLayer: { kind: 'particles'; particles: ParticleLayer } | null;
  liveRings(t: number): LiveRing[];
  analyticWaves(): Wave[];
  sample(x0: number, z0: number, t: number, derivatives?: boolean): SurfaceSample;
  invert(x: number, z: number, t: number, derivatives?: boolean, inversion?: Inversion):
    { source: Vec2; sample: SurfaceSample; residual: number; iterations: number };
  height(x: number, z: number, t: number, inversion?: Inversion): number;
  query(x: number, z: number, t: number, fields?: FieldName[], inversion?: Inversion): PointResult;
  uniforms(t: number, origin?: Vec2): { t: number; origin: Vec2; phases: number[]; block: Float32Array; ringsDropped: number };
}
export interface RingState { distance: number; generation: number; count: number; amplitude: number }
export class Ring {
  readonly t0: number; readonly center: Vec2; readonly radius: number; readonly speed: number; readonly n0: number; readonly a0: number;
  splitDistance(g: number): number;
  state(t: number): RingState | null;
}
export class ImpactSet {
  constructor(events?: Impact[]);
  readonly events: Impact[]; readonly size: number; readonly version: number;
  add(e: Impact): boolean;
  addAll(list: Impact[]): number;
  prune(t: number, keep: number): void;
  window(t: number, lifetime: number): Impact[];
}
export function canonicalCmp(a: Impact, b: Impact): number;
/** Rings that count at one point at most: where more cover it, the newest this many. */
export const MAX_RINGS_PER_POINT: number;
export class ParticleLayer {
  constructor(derivedLayer: Record<string, any>, dispersion?: { gravity?: number; depth?: number | null }, where?: string);
  readonly count: number; readonly tile: number; readonly radius: number; readonly scales: number[];
  /** Whether the particles are the model's exact values (`particles_tile`, or a power-of-two tile). */
  readonly exact: boolean;
  readonly ripples: { particles: number; decay: number; floor: number; lifetime: number; max_ring_particles: number };
  ring(impact: Impact): Ring;
  position(i: number, t: number): Vec2;
  liveRings(t: number, impacts: ImpactSet): LiveRing[];
  /** Whether a live ring's annulus covers (x, z); at most MAX_RINGS_PER_POINT covering rings count there. */
  covers(ring: LiveRing, x: number, z: number): boolean;
  sample(x: number, z: number, t: number, rings?: LiveRing[], out?: number[]): [number, number, number];
  shaderBlock(t: number, origin: Vec2, impacts: ImpactSet): { values: Float32Array; ringsDropped: number };
}
export function normalOf(s: SurfaceSample): Vec3;
export function jacobianOf(s: SurfaceSample): number;

export class FftLayer {
  constructor(spectrum: Spectrum, options?: { cacheFrames?: number });
  readonly n: number; readonly L: number;
  frame(t: number): { t: number; h: Float64Array; dx: Float64Array; dz: Float64Array; sx: Float64Array; sz: Float64Array; jxx: Float64Array; jzz: Float64Array; jxz: Float64Array };
  sample(x0: number, z0: number, t: number, derivatives?: boolean): SurfaceSample;
}
export function parseSpectrum(bytes: Uint8Array | ArrayBuffer): Spectrum;
export function ifft2(re: Float64Array, im: Float64Array, n: number): void;

export function reducePhase(x: number): number;
export function sinCos(x: number, out?: [number, number]): [number, number];
export function roundTiesAway(x: number): number;
export function bitsHex(x: number): string;
export function fromBitsHex(hex: string): number;

export function encodeSampleRequest(req: SampleRequest): Uint8Array;
export function encodeOrientationRequest(req: OrientationRequest): Uint8Array;
export function decodeSampleResponse(bytes: Uint8Array): SampleResponse;
export function decodeOrientationResponse(bytes: Uint8Array): OrientationResponse;
export function decodeHeightResponse(bytes: Uint8Array): { t: number; height: number };
export function decodeErrorResponse(bytes: Uint8Array): { code: string; message: string; field?: string };
export function checkSceneId(id: string): string;
export function checkSample(req: SampleRequest): SampleRequest;
export function checkOrientation(req: OrientationRequest): OrientationRequest;
