// Renders the job of tests/khronos_render.rs with the Khronos glTF Sample Renderer (npm
// `@khronosgroup/gltf-viewer`, the renderer of the glTF Sample Viewer, pinned in package.json) in
// WebGL2, lit by a `hdrflow bake --for khronos` folder, and reads the frames back as 32-bit floats.
//
// The job (GET ../work/job.json); paths are relative to ../work/:
//   { "renders": [ { "name", "kind": "spheres", "ibl": DIR, "environment_rotation": DEGREES, "sun": README? }
//                | { "name", "kind": "sky", "ibl": DIR, "forward": [x, 0, z], "fov_deg", "size",
//                    "environment_rotation": DEGREES } ],
//     "ktx2": [ paths ] }
// DIR is a bake folder: ggx/specular.ktx2, lambertian/diffuse.ktx2, charlie/sheen.ktx2,
// lut_ggx.png, lut_charlie.png. Results are POSTed to ../result/NAME: NAME.f32 (RGBA f32 rows, top
// row first), scene.json (clients/web-common/scene.js's geometry), shaders.txt (the shaders the
// renderer compiled, for the record) and last report.json (per render: what was
// loaded, the renderer's settings; per KTX2 file what ktx-parse read; errors).
//
// The environment. The renderer's `ResourceLoader.loadEnvironment` takes a panorama and filters it
// at run time (its iblSampler); the glTF Sample Viewer's earlier releases loaded glTF-IBL-Sampler's
// files instead, and the renderer still carries that code, commented out, beside the run-time path
// (`_loadEnvironmentFromPanorama`). This page builds the same environment object from the bake's
// files: each KTX2 file through the renderer's own KTX reader (`KtxDecoder.loadKtxFromBuffer`:
// libktx, KTX-Software's WebAssembly build that the package ships, uploads the cube map and its
// mips), each LUT as a PNG image the renderer uploads itself (as it uploads its own
// `lut_sheen_E.png`: 8 bits per channel through an HTML image), the same samplers, `mipCount` the
// chain's level count (the renderer reads lod = roughness (mipCount - 1)) and intensity scale 1.
// The cube textures carry the sampler state the run-time filter gives its own
// (`iblSampler.createCubemapTexture`: trilinear for the chains, linear for the Lambertian map,
// clamped), and are marked initialised as the run-time path marks them.
//
// Float readback. The renderer draws its final pass into the default framebuffer, tone-mapped
// (`toneMap`: colour x exposure, a tone curve, then pow(1 / 2.2)). The page asks for no tone curve
// (`ToneMaps.NONE`) at exposure 1 and binds, wherever the renderer binds the default framebuffer,
// an RGBA32F texture of its own (EXT_color_buffer_float), so nothing is clamped or quantised; the
// frame read from it is raised to the power 2.2 here, which undoes the renderer's pow exactly up
// to float rounding. Spheres: the environment is not drawn behind them and the clear colour is
// transparent black. Sky: only the environment, the renderer's skybox pass (`drawEnvironmentMap`,
// the specular chain's level 0 with blur off) through a perspective glTF camera at the origin.
// Each render is drawn twice; the two frames must be equal.
//
// The sun. A spheres render with "sun" (a bake's README.txt, `hdrflow bake --sun extract`) adds the
// light its lines under "The sun:" give (src/ibl_presets/khronos.rs, `sun_code`): the
// KHR_lights_punctual "lights" array as written, on a node whose rotation turns its -Z onto the
// direction the lines name, with the renderer's punctual lights on (tests/common/sun_lines.rs).

import { GltfView, GltfState } from './node_modules/@khronosgroup/gltf-viewer/dist/gltf-viewer.module.js';
import { read as readKtx2 } from './node_modules/ktx-parse/dist/index.mjs';
import * as Scene from '../common/scene.js';
import { getBytes, getJson, log, post, readSunLines, run } from '../common/page.js';

const LIBS = 'node_modules/@khronosgroup/gltf-viewer/dist/libs/';

/// The WebGL2 context the renderer will use, with the default framebuffer redirected to
/// `redirect.target` when one is set, and the shader sources recorded.
function instrumentedContext(canvas) {
    const gl = canvas.getContext('webgl2', { antialias: false, depth: true, alpha: true });
    if (!gl) {
        throw new Error('no WebGL2 context');
    }
    if (!gl.getExtension('EXT_color_buffer_float')) {
        throw new Error('no EXT_color_buffer_float: float render targets are not renderable');
    }
    const redirect = { target: null, shaders: [] };
    const bindFramebuffer = gl.bindFramebuffer.bind(gl);
    gl.bindFramebuffer = (target, fb) => bindFramebuffer(target, fb === null ? redirect.target : fb);
    gl.bindFramebufferDirect = bindFramebuffer;
    const shaderSource = gl.shaderSource.bind(gl);
    gl.shaderSource = (shader, src) => {
        redirect.shaders.push(src);
        shaderSource(shader, src);
    };
    return { gl, redirect };
}

/// An RGBA32F colour texture with a depth buffer, w x h.
function floatTarget(gl, w, h) {
    const color = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, color);
    gl.texStorage2D(gl.TEXTURE_2D, 1, gl.RGBA32F, w, h);
    const depth = gl.createRenderbuffer();
    gl.bindRenderbuffer(gl.RENDERBUFFER, depth);
    gl.renderbufferStorage(gl.RENDERBUFFER, gl.DEPTH_COMPONENT24, w, h);
    const fb = gl.createFramebuffer();
    gl.bindFramebufferDirect(gl.FRAMEBUFFER, fb);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, color, 0);
    gl.framebufferRenderbuffer(gl.FRAMEBUFFER, gl.DEPTH_ATTACHMENT, gl.RENDERBUFFER, depth);
    const status = gl.checkFramebufferStatus(gl.FRAMEBUFFER);
    gl.bindFramebufferDirect(gl.FRAMEBUFFER, null);
    if (status !== gl.FRAMEBUFFER_COMPLETE) {
        throw new Error('float framebuffer incomplete: 0x' + status.toString(16));
    }
    return { fb, color, depth, w, h };
}

/// The target's pixels, top row first, each colour channel raised to 2.2 (module doc).
function readLinear(gl, t) {
    gl.bindFramebufferDirect(gl.READ_FRAMEBUFFER, t.fb);
    const bottomUp = new Float32Array(t.w * t.h * 4);
    gl.readPixels(0, 0, t.w, t.h, gl.RGBA, gl.FLOAT, bottomUp);
    gl.bindFramebufferDirect(gl.READ_FRAMEBUFFER, null);
    const out = new Float32Array(t.w * t.h * 4);
    for (let y = 0; y < t.h; y++) {
        const row = bottomUp.subarray((t.h - 1 - y) * t.w * 4, (t.h - y) * t.w * 4);
        for (let i = 0; i < row.length; i++) {
            out[y * t.w * 4 + i] = i % 4 === 3 ? row[i] : Math.pow(row[i], 2.2);
        }
    }
    return { pixels: out, raw: bottomUp };
}

/// What ktx-parse (an independent KTX 2.0 reader) finds in a .ktx2 file.
function ktx2Report(bytes) {
    const c = readKtx2(bytes);
    const d = c.dataFormatDescriptor[0];
    return {
        vkFormat: c.vkFormat,
        size: [c.pixelWidth, c.pixelHeight, c.pixelDepth],
        faces: c.faceCount,
        supercompression: c.supercompressionScheme,
        colorModel: d.colorModel,
        transferFunction: d.transferFunction,
        levels: c.levels.map(l => [l.levelData.byteLength, l.uncompressedByteLength]),
    };
}

function loadImage(url) {
    return new Promise((resolve, reject) => {
        const image = new Image();
        image.addEventListener('load', () => resolve(image));
        image.addEventListener('error', () => reject(new Error('could not decode ' + url)));
        image.src = url;
    });
}

/// The environment object the renderer reads (`state.environment`: samplers, images, textures,
/// the texture infos, `mipCount`, `iblIntensityScale`) made from the bake in `dir` (module doc).
async function loadBake(gl, view, dir) {
    const decoder = view.ktxDecoder;
    const env = { samplers: [], images: [], textures: [], iblIntensityScale: 1.0, loaded: {} };
    // The samplers of _loadEnvironmentFromPanorama.
    const sampler = (mag, min, name) => {
        env.samplers.push({ magFilter: mag, minFilter: min, wrapS: gl.CLAMP_TO_EDGE, wrapT: gl.CLAMP_TO_EDGE, name });
        return env.samplers.length - 1;
    };
    const diffuseSampler = sampler(gl.LINEAR, gl.LINEAR, 'DiffuseCubeMapSampler');
    const specularSampler = sampler(gl.LINEAR, gl.LINEAR_MIPMAP_LINEAR, 'SpecularCubeMapSampler');
    const sheenSampler = sampler(gl.LINEAR, gl.LINEAR_MIPMAP_LINEAR, 'SheenCubeMapSampler');
    const lutSampler = sampler(gl.LINEAR, gl.LINEAR, 'LUTSampler');
    const info = index => ({ index, texCoord: 0, linear: true, generateMips: false });

    const cube = async (file, samplerIndex, mipmapped) => {
        const bytes = await getBytes(dir + '/' + file);
        const parsed = readKtx2(bytes);
        const tex = await decoder.loadKtxFromBuffer(bytes);
        if (!tex) {
            throw new Error(`${dir}/${file}: the renderer's KTX reader (libktx) could not load it`);
        }
        gl.bindTexture(gl.TEXTURE_CUBE_MAP, tex);
        gl.texParameteri(gl.TEXTURE_CUBE_MAP, gl.TEXTURE_MIN_FILTER, mipmapped ? gl.LINEAR_MIPMAP_LINEAR : gl.LINEAR);
        gl.texParameteri(gl.TEXTURE_CUBE_MAP, gl.TEXTURE_MAG_FILTER, gl.LINEAR);
        gl.texParameteri(gl.TEXTURE_CUBE_MAP, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
        gl.texParameteri(gl.TEXTURE_CUBE_MAP, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
        env.images.push({ mimeType: 'image/ktx2', image: tex, type: gl.TEXTURE_CUBE_MAP, miplevel: 0, name: file });
        env.textures.push({ sampler: samplerIndex, source: env.images.length - 1, type: gl.TEXTURE_CUBE_MAP, initialized: true, glTexture: undefined });
        env.loaded[file] = { size: parsed.pixelWidth, levels: parsed.levels.length, faces: parsed.faceCount, vkFormat: parsed.vkFormat };
        return { info: info(env.textures.length - 1), levels: parsed.levels.length };
    };
    const lut = async file => {
        const image = await loadImage('../work/' + dir + '/' + file);
        env.images.push({ mimeType: 'image/png', image, type: gl.TEXTURE_2D, miplevel: 0, name: file });
        env.textures.push({ sampler: lutSampler, source: env.images.length - 1, type: gl.TEXTURE_2D, initialized: false, glTexture: undefined });
        env.loaded[file] = { size: [image.naturalWidth, image.naturalHeight] };
        return info(env.textures.length - 1);
    };

    env.diffuseEnvMap = (await cube('lambertian/diffuse.ktx2', diffuseSampler, false)).info;
    const specular = await cube('ggx/specular.ktx2', specularSampler, true);
    env.specularEnvMap = specular.info;
    const sheen = await cube('charlie/sheen.ktx2', sheenSampler, true);
    env.sheenEnvMap = sheen.info;
    if (sheen.levels !== specular.levels) {
        throw new Error(`${dir}: the sheen chain has ${sheen.levels} levels, the specular ${specular.levels} (the renderer reads both with one mipCount)`);
    }
    env.lut = await lut('lut_ggx.png');
    env.sheenLUT = await lut('lut_charlie.png');
    env.mipCount = specular.levels;
    return env;
}

/// The sun of a README's lines under "The sun:" (`text`): the KHR_lights_punctual "lights" array
/// and the direction its node's -Z points along, both read as the lines write them.
function khrSun(text) {
    const lights = text.match(/"lights":\s*(\[.*\])/);
    const along = text.match(/-Z axis points along \(([^)]*)\)/);
    if (!lights || !along) {
        throw new Error('the sun lines name no KHR_lights_punctual "lights" array or no -Z direction:\n' + text);
    }
    const d = along[1].split(',').map(Number);
    const len = Math.hypot(...d);
    if (d.length !== 3 || !(len > 0)) {
        throw new Error('the sun lines\' direction is not a vector: ' + along[1]);
    }
    return { lights: JSON.parse(lights[1]), along: d.map(v => v / len) };
}

/// The unit quaternion (x, y, z, w) that turns -Z onto the unit vector `f`: half the angle about
/// -Z x f, (f_y, -f_x, 0) with w = 1 - f_z before normalising; f = +Z, a half turn about +Y.
function negativeZOnto(f) {
    const q = [f[1], -f[0], 0, 1 - f[2]];
    const n = Math.hypot(...q);
    return n > 1e-9 ? q.map(v => v / n) : [0, 1, 0, 0];
}

/// The glTF of a render: the spheres (scene 0) with an orthographic camera on +Z, or (scene 1)
/// a perspective camera at the origin looking along the horizontal `forward`; `sun`: khrSun's
/// light, on a node of scene 0.
function sceneGlb(job, sun) {
    const { gltf, bin } = Scene.spheresGltf();
    gltf.asset.generator = 'hdrflow clients/khronos-web';
    const halfH = Scene.VIEW_WIDTH * Scene.HEIGHT / Scene.WIDTH / 2;
    gltf.cameras = [
        { type: 'orthographic', orthographic: { xmag: Scene.VIEW_WIDTH / 2, ymag: halfH, znear: 1.0, zfar: 20.0 } },
    ];
    gltf.nodes.push({ name: 'spheres camera', camera: 0, translation: [0, 0, Scene.CAMERA_Z] });
    gltf.scenes[0].nodes.push(gltf.nodes.length - 1);
    if (sun) {
        gltf.extensionsUsed = [...(gltf.extensionsUsed || []), 'KHR_lights_punctual'];
        gltf.extensions = { ...(gltf.extensions || {}), KHR_lights_punctual: { lights: sun.lights } };
        gltf.nodes.push({ name: 'sun', rotation: negativeZOnto(sun.along), extensions: { KHR_lights_punctual: { light: 0 } } });
        gltf.scenes[0].nodes.push(gltf.nodes.length - 1);
    }
    if (job.kind === 'sky') {
        // A glTF camera looks along -Z; turned by theta about +Y it looks along (-sin, 0, -cos).
        const [fx, , fz] = job.forward;
        const theta = Math.atan2(-fx, -fz);
        gltf.cameras.push({ type: 'perspective', perspective: { yfov: job.fov_deg * Math.PI / 180, aspectRatio: 1.0, znear: 0.1, zfar: 10.0 } });
        gltf.nodes.push({ name: 'sky camera', camera: 1, rotation: [0, Math.sin(theta / 2), 0, Math.cos(theta / 2)] });
        gltf.scenes.push({ nodes: [gltf.nodes.length - 1] });
    }
    return Scene.toGlb(gltf, bin);
}

async function render(gl, redirect, view, loader, job, environments) {
    const state = view.createState();
    const lines = job.sun ? await readSunLines(job.sun) : null;
    const sun = lines === null ? null : khrSun(lines);
    state.gltf = await loader.loadGltf(sceneGlb(job, sun).buffer);
    const sky = job.kind === 'sky';
    state.sceneIndex = sky ? 1 : 0;
    state.cameraIndex = sky ? 1 : 0;
    if (!environments.has(job.ibl)) {
        environments.set(job.ibl, await loadBake(gl, view, job.ibl));
    }
    state.environment = environments.get(job.ibl);
    const p = state.renderingParameters;
    p.toneMap = GltfState.ToneMaps.NONE;
    p.exposure = 1.0;
    p.iblIntensity = 1.0;
    p.useIBL = true;
    p.usePunctual = sun !== null;
    p.renderEnvironmentMap = sky;
    p.blurEnvironmentMap = false;
    p.environmentRotation = job.environment_rotation;
    p.clearColor = [0, 0, 0, 0];
    const [w, h] = sky ? [job.size, job.size] : [Scene.WIDTH, Scene.HEIGHT];
    const target = floatTarget(gl, w, h);
    redirect.target = target.fb;
    const frames = [];
    for (let k = 0; k < 2; k++) {
        await new Promise(r => setTimeout(r, 0));
        view.renderFrame(state, w, h);
        frames.push(readLinear(gl, target));
    }
    redirect.target = null;
    const [a, b] = frames;
    const stable = a.raw.every((v, i) => v === b.raw[i] || (Number.isNaN(v) && Number.isNaN(b.raw[i])));
    return {
        pixels: b.pixels,
        stable,
        sun: lines,
        lights: (state.gltf.lights || []).map(l => ({ type: l.type, color: Array.from(l.color), intensity: l.intensity })),
        settings: { toneMap: p.toneMap, exposure: p.exposure, iblIntensity: p.iblIntensity, environmentRotation: p.environmentRotation, mipCount: state.environment.mipCount, iblIntensityScale: state.environment.iblIntensityScale },
    };
}

async function main() {
    const job = await getJson('job.json');
    const report = { package: null, renders: [], ktx2: {}, loaded: {}, errors: [] };
    report.package = (await (await fetch('node_modules/@khronosgroup/gltf-viewer/package.json')).json()).version;
    const canvas = document.getElementById('canvas');
    const { gl, redirect } = instrumentedContext(canvas);
    report.webgl = { version: gl.getParameter(gl.VERSION), renderer: gl.getParameter(gl.RENDERER) };
    const view = new GltfView(gl);
    const loader = view.createResourceLoader(undefined, undefined, LIBS);
    await post('scene.json', JSON.stringify(Scene.geometryJson(1.0, 1.0), null, 2));

    for (const path of job.ktx2 || []) {
        try {
            report.ktx2[path] = ktx2Report(await getBytes(path));
        } catch (e) {
            report.errors.push(`${path}: ${e}`);
        }
    }
    const environments = new Map();
    for (const entry of job.renders) {
        try {
            const out = await render(gl, redirect, view, loader, entry, environments);
            await post(entry.name + '.f32', out.pixels.buffer);
            report.renders.push({ name: entry.name, stable: out.stable, settings: out.settings, sun: out.sun, lights: out.lights });
            log(`${entry.name}: done`);
        } catch (e) {
            report.errors.push(`${entry.name}: ${e}\n${e.stack || ''}`);
            log(`${entry.name}: ${e}`);
        }
    }
    for (const [dir, env] of environments) {
        report.loaded[dir] = env.loaded;
    }
    await post('shaders.txt', redirect.shaders.join('\n// ======== next shader ========\n'));
    await post('report.json', JSON.stringify(report, null, 1));
}

run(main);
