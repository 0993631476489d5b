// The fixed scene of the web engine tests (clients/filament-web, clients/khronos-web), declared
// once here and written out as scene.json for the test (the same fields as clients/bevy's
// --geometry, read by tests/bevy_render/scene.rs): six spheres in a row,
// seen by an orthographic camera on +Z looking down -Z with +Y up, 768 x 256 pixels spanning
// 6 x 2 world units; sphere k (0..6) has centre (k - 2.5, 0, 0) and radius 0.45.
//
// Materials are glTF metallic-roughness materials rendered by gltfio's ubershaders, base colour
// white: a mirror (metallic 1, roughness 0, which Filament clamps to its minimum perceptual
// roughness), four metals of roughness 0.25 to 1, and a white dielectric of roughness 1 (glTF's
// default IOR 1.5: F0 = 0.04, written as reflectance 0.5 since F0 = 0.16 reflectance^2).

export const WIDTH = 768;
export const HEIGHT = 256;
export const VIEW_WIDTH = 6.0;
export const PIXEL_SIZE = VIEW_WIDTH / WIDTH;
export const RADIUS = 0.45;
export const CAMERA_Z = 10.0;

export const SPHERES = [
    { name: 'mirror', metallic: 1.0, perceptual_roughness: 0.0 },
    { name: 'metal_0.25', metallic: 1.0, perceptual_roughness: 0.25 },
    { name: 'metal_0.5', metallic: 1.0, perceptual_roughness: 0.5 },
    { name: 'metal_0.75', metallic: 1.0, perceptual_roughness: 0.75 },
    { name: 'metal_1', metallic: 1.0, perceptual_roughness: 1.0 },
    { name: 'diffuse', metallic: 0.0, perceptual_roughness: 1.0 },
];

export function centreX(k) {
    return k - 2.5;
}

/// The scene as tests/bevy_render/scene.rs reads it. `exposure` is Filament's camera exposure
/// 1 / (1.2 2^EV100) for aperture 1, shutter 1.2 s, ISO 100 (EV100 = log2(1 / 1.2)): exactly 1,
/// and `intensity` the IndirectLight's: pixels are the map's radiance units.
export function geometryJson(exposure, intensity) {
    return {
        projection: 'orthographic',
        view_direction: [0, 0, 1],
        width: WIDTH,
        height: HEIGHT,
        view_width: VIEW_WIDTH,
        view_height: VIEW_WIDTH * HEIGHT / WIDTH,
        pixel_size: PIXEL_SIZE,
        exposure,
        intensity,
        spheres: SPHERES.map((s, k) => ({
            name: s.name,
            centre: [centreX(k), 0, 0],
            radius: RADIUS,
            base_color: [1, 1, 1],
            metallic: s.metallic,
            perceptual_roughness: s.perceptual_roughness,
            reflectance: 0.5,
        })),
    };
}

/// A UV sphere of `radius` at the origin: positions and unit normals (f32, interleaved as two
/// arrays) and u32 triangle indices, `segments` around, `rings` from pole to pole.
function uvSphere(radius, segments, rings) {
    const positions = [];
    const normals = [];
    for (let j = 0; j <= rings; j++) {
        const theta = Math.PI * j / rings;
        for (let i = 0; i <= segments; i++) {
            const phi = 2 * Math.PI * i / segments;
            const n = [Math.sin(theta) * Math.cos(phi), Math.cos(theta), -Math.sin(theta) * Math.sin(phi)];
            normals.push(...n);
            positions.push(...n.map(c => c * radius));
        }
    }
    const indices = [];
    const row = segments + 1;
    for (let j = 0; j < rings; j++) {
        for (let i = 0; i < segments; i++) {
            const a = j * row + i, b = a + row;
            // Counter-clockwise seen from outside.
            indices.push(a, b, a + 1, a + 1, b, b + 1);
        }
    }
    return { positions: new Float32Array(positions), normals: new Float32Array(normals), indices: new Uint32Array(indices) };
}

/// The six spheres as one binary glTF (GLB): one mesh shared by six nodes, one material each.
export function spheresGlb() {
    const { gltf, bin } = spheresGltf();
    return toGlb(gltf, bin);
}

/// The six spheres as glTF JSON (scene 0: the spheres' nodes 0..6) and its one binary buffer, for
/// a client to add to (cameras, scenes) before packing it with `toGlb`.
export function spheresGltf() {
    const mesh = uvSphere(RADIUS, 256, 128);
    const bin = [mesh.positions, mesh.normals, mesh.indices];
    const offsets = [];
    let length = 0;
    for (const b of bin) {
        offsets.push(length);
        length += b.byteLength;
    }
    const count = mesh.positions.length / 3;
    const gltf = {
        asset: { version: '2.0', generator: 'hdrflow clients/filament-web' },
        scene: 0,
        scenes: [{ nodes: SPHERES.map((_, k) => k) }],
        nodes: SPHERES.map((s, k) => ({ name: s.name, mesh: k, translation: [centreX(k), 0, 0] })),
        meshes: SPHERES.map((s, k) => ({
            name: s.name,
            primitives: [{ attributes: { POSITION: 0, NORMAL: 1 }, indices: 2, material: k }],
        })),
        materials: SPHERES.map(s => ({
            name: s.name,
            pbrMetallicRoughness: {
                baseColorFactor: [1, 1, 1, 1],
                metallicFactor: s.metallic,
                roughnessFactor: s.perceptual_roughness,
            },
        })),
        buffers: [{ byteLength: length }],
        bufferViews: [
            { buffer: 0, byteOffset: offsets[0], byteLength: bin[0].byteLength, target: 34962 },
            { buffer: 0, byteOffset: offsets[1], byteLength: bin[1].byteLength, target: 34962 },
            { buffer: 0, byteOffset: offsets[2], byteLength: bin[2].byteLength, target: 34963 },
        ],
        accessors: [
            { bufferView: 0, componentType: 5126, count, type: 'VEC3', min: [-RADIUS, -RADIUS, -RADIUS], max: [RADIUS, RADIUS, RADIUS] },
            { bufferView: 1, componentType: 5126, count, type: 'VEC3' },
            { bufferView: 2, componentType: 5125, count: mesh.indices.length, type: 'SCALAR' },
        ],
    };
    const bytes = new Uint8Array(length);
    for (let k = 0; k < bin.length; k++) {
        bytes.set(new Uint8Array(bin[k].buffer, bin[k].byteOffset, bin[k].byteLength), offsets[k]);
    }
    return { gltf, bin: bytes };
}

/// `gltf` and its binary buffer `bin` as a GLB file (glTF 2.0, section 4.4: a JSON chunk padded
/// with spaces, a BIN chunk).
export function toGlb(gltf, bin) {
    const length = bin.byteLength;
    let json = new TextEncoder().encode(JSON.stringify(gltf));
    const jsonPad = (4 - (json.length % 4)) % 4;
    const jsonChunk = new Uint8Array(json.length + jsonPad).fill(0x20);
    jsonChunk.set(json);
    const total = 12 + 8 + jsonChunk.length + 8 + length;
    const out = new Uint8Array(total);
    const dv = new DataView(out.buffer);
    dv.setUint32(0, 0x46546c67, true); // 'glTF'
    dv.setUint32(4, 2, true);
    dv.setUint32(8, total, true);
    dv.setUint32(12, jsonChunk.length, true);
    dv.setUint32(16, 0x4e4f534a, true); // 'JSON'
    out.set(jsonChunk, 20);
    let at = 20 + jsonChunk.length;
    dv.setUint32(at, length, true);
    dv.setUint32(at + 4, 0x004e4942, true); // 'BIN\0'
    out.set(bin, at + 8);
    return out;
}
