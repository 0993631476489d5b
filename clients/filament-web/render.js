// Renders the job of tests/filament_render.rs with Filament's web build (npm `filament`, pinned in
// package.json) in WebGL2, and reads the frames back as 32-bit floats.
//
// The job (GET ../work/job.json) lists renders and KTX files:
//   { "renders": [ { "name", "kind": "spheres", "ibl": "x_ibl.ktx", "sh": "sh.txt" (optional)
//                    "specular_aa": [variance, threshold] (optional), "ibl_intensity" (optional, 1),
//                    "sun": "x/README.txt" (optional) }
//                  | { "name", "kind": "sky", "sky": "x_skybox.ktx", "forward": [x, y, z],
//                      "up": [x, y, z], "fov_deg", "size" } ],
//     "ktx1": [ paths ], "ktx2": [ paths ] }
// Paths are relative to ../work/. Results are POSTed to ../result/NAME: NAME.f32 (RGBA f32 rows,
// top row first), scene.json (scene.js's geometry), shaders.txt (the fragment shaders Filament
// compiled, for the record) and last report.json (per render: frames and time; per KTX file: what
// Filament's Ktx1Bundle or ktx-parse read; errors).
//
// Spheres: the glTF of scene.js through gltfio (createAssetLoader: its ubershaders), lit only by
// an IndirectLight made of the KTX1 chain (Ktx1Bundle, ktx1reader) and 9 SH, from the file's
// "sh" key unless the job names a text file (cmgen's sh.txt layout), intensity 1; camera
// exposure 1 (aperture 1, 1.2 s, ISO 100). With "ibl_intensity" I (the README's 30000 lux per
// unit of the map), the IBL's intensity is I and the exposure 1 / I: the frame is still in the
// map's units, and a sun the README sizes for that intensity is lit as a user's would be. With
// "sun", the sun's lines of that README (a `--sun extract` bake), C++, translated token by token
// into filament.js (sun_lines.js, which throws on anything it does not know) and run with the
// render's `engine` and `scene` (page.js, `runSunLines`). Post-processing off, so no tone
// mapping, colour grading, dithering, anti-aliasing or MSAA: the colour pass writes linear
// radiance into an RGBA32F render target. Sky: a Skybox of the KTX1 cube seen by a perspective camera at the
// origin.
//
// Float readback: Filament's JavaScript API has no readPixels, so the page creates the WebGL2
// context itself (Filament's Engine.create reuses it), records which texture Filament allocates
// for the render target (texStorage2D, RGBA32F, the target's size) and reads it through a
// framebuffer of its own with gl.readPixels(RGBA, FLOAT) (EXT_color_buffer_float), restoring the
// read binding after. A render is read after each frame until two frames in a row are equal and
// not empty (shaders may compile over several frames).

import { read as readKtx2 } from './node_modules/ktx-parse/dist/index.mjs';
import * as Scene from '../common/scene.js';
import { getBytes, getJson, log, post, run, runSunLines } from '../common/page.js';
import { translateSunLines } from './sun_lines.js';

/// The WebGL2 context Filament will use, instrumented: textures allocated with texStorage2D and
/// fragment shader sources.
function instrumentedContext(canvas) {
    const gl = canvas.getContext('webgl2', { majorVersion: 2, minorVersion: 0, antialias: false, depth: true, alpha: false });
    if (!gl) {
        throw new Error('no WebGL2 context');
    }
    if (!gl.getExtension('EXT_color_buffer_float')) {
        throw new Error('no EXT_color_buffer_float: float render targets are not renderable');
    }
    const state = { textures: [], shaders: [], active: gl.TEXTURE0, bound: new Map() };
    const bindTexture = gl.bindTexture.bind(gl);
    const activeTexture = gl.activeTexture.bind(gl);
    const texStorage2D = gl.texStorage2D.bind(gl);
    const shaderSource = gl.shaderSource.bind(gl);
    gl.activeTexture = unit => {
        state.active = unit;
        activeTexture(unit);
    };
    gl.bindTexture = (target, tex) => {
        if (target === gl.TEXTURE_2D) {
            state.bound.set(state.active, tex);
        }
        bindTexture(target, tex);
    };
    gl.texStorage2D = (target, levels, format, w, h) => {
        if (target === gl.TEXTURE_2D) {
            state.textures.push({ tex: state.bound.get(state.active), format, w, h });
        }
        texStorage2D(target, levels, format, w, h);
    };
    gl.shaderSource = (shader, src) => {
        state.shaders.push(src);
        shaderSource(shader, src);
    };
    return { gl, state };
}

/// RGBA f32 pixels of `tex` (w x h), top row first.
function readTexture(gl, tex, w, h) {
    const previous = gl.getParameter(gl.READ_FRAMEBUFFER_BINDING);
    const fb = gl.createFramebuffer();
    gl.bindFramebuffer(gl.READ_FRAMEBUFFER, fb);
    gl.framebufferTexture2D(gl.READ_FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, tex, 0);
    const status = gl.checkFramebufferStatus(gl.READ_FRAMEBUFFER);
    const bottomUp = new Float32Array(w * h * 4);
    if (status === gl.FRAMEBUFFER_COMPLETE) {
        gl.readPixels(0, 0, w, h, gl.RGBA, gl.FLOAT, bottomUp);
    }
    gl.bindFramebuffer(gl.READ_FRAMEBUFFER, previous);
    gl.deleteFramebuffer(fb);
    if (status !== gl.FRAMEBUFFER_COMPLETE) {
        throw new Error('readback framebuffer incomplete: 0x' + status.toString(16));
    }
    const out = new Float32Array(w * h * 4);
    for (let y = 0; y < h; y++) {
        out.set(bottomUp.subarray((h - 1 - y) * w * 4, (h - y) * w * 4), y * w * 4);
    }
    return out;
}

function sameFrame(a, b) {
    if (!a || a.length !== b.length) {
        return false;
    }
    for (let i = 0; i < a.length; i++) {
        if (a[i] !== b[i] && !(Number.isNaN(a[i]) && Number.isNaN(b[i]))) {
            return false;
        }
    }
    return true;
}

/// cmgen's sh.txt: 9 lines "( r, g, b); // comment"; 27 floats.
function parseShText(text) {
    const out = [];
    for (const line of text.split('\n')) {
        const body = line.split('//')[0];
        const nums = body.match(/[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?/g);
        if (nums) {
            out.push(...nums.map(parseFloat));
        }
    }
    if (out.length !== 27) {
        throw new Error(`sh.txt: ${out.length} numbers, not 27`);
    }
    return out;
}

function ktx1Bundle(bytes) {
    const bd = new Filament.driver$BufferDescriptor(bytes.byteLength);
    bd.getBytes().set(bytes);
    return new Filament.Ktx1Bundle(bd);
}

/// What Filament's own KTX1 reader (libs/ktxreader's Ktx1Bundle) finds in a .ktx file: the
/// header fields, each cube level's blob size, the `sh` key as Filament's createIblFromKtx1
/// splits it.
function ktx1Report(bytes) {
    const k = ktx1Bundle(bytes);
    const info = k.info();
    const sh = k.getMetadata('sh');
    const cubeBlobs = [];
    for (let l = 0; k.isCubemap() && l < k.getNumMipLevels(); l++) {
        const blob = k._getCubeBlob(l);
        cubeBlobs.push(blob.getBytes().byteLength);
        blob.delete();
    }
    return {
        cube: k.isCubemap(),
        levels: k.getNumMipLevels(),
        size: [info.pixelWidth, info.pixelHeight],
        glInternalFormat: info.glInternalFormat,
        glFormat: info.glFormat,
        glType: info.glType,
        glTypeSize: info.glTypeSize,
        faces: info.numberOfFaces,
        internalFormat: k.getInternalFormat(false).constructor.name,
        pixelDataFormat: k.getPixelDataFormat().constructor.name,
        pixelDataType: k.getPixelDataType().constructor.name,
        cubeBlobs,
        sh: sh ? sh.split(/\s/, 27).map(parseFloat) : null,
    };
}

/// What ktx-parse (an independent KTX 2.0 reader) finds in a .ktx2 file.
function ktx2Report(bytes) {
    const c = readKtx2(bytes);
    const d = c.dataFormatDescriptor[0];
    return {
        vkFormat: c.vkFormat,
        typeSize: c.typeSize,
        size: [c.pixelWidth, c.pixelHeight, c.pixelDepth],
        layers: c.layerCount,
        faces: c.faceCount,
        supercompression: c.supercompressionScheme,
        colorModel: d.colorModel,
        transferFunction: d.transferFunction,
        bytesPlane0: d.bytesPlane[0],
        samples: d.samples.map(s => [s.bitOffset, s.bitLength + 1, s.channelType, s.sampleLower, s.sampleUpper]),
        levels: c.levels.map(l => [l.levelData.byteLength, l.uncompressedByteLength]),
        keys: Object.keys(c.keyValue),
    };
}

/// Filament's TextureUsage bits (filament.d.ts: a const enum, plain numbers in JavaScript).
const USAGE = { COLOR_ATTACHMENT: 1, DEPTH_ATTACHMENT: 2, SAMPLEABLE: 16 };

class Renderer {
    constructor(canvas) {
        const { gl, state } = instrumentedContext(canvas);
        this.gl = gl;
        this.state = state;
        this.engine = Filament.Engine.create(canvas);
        this.renderer = this.engine.createRenderer();
        this.swapChain = this.engine.createSwapChain();
        this.renderer.setClearOptions({ clearColor: [0, 0, 0, 0], clear: true });
    }

    /// A view rendering `scene` through `camera` into a new RGBA32F target of w x h.
    view(scene, camera, w, h) {
        const F = Filament;
        const before = this.state.textures.length;
        const color = F.Texture.Builder().width(w).height(h).levels(1)
            .sampler(F.Texture$Sampler.SAMPLER_2D).format(F.Texture$InternalFormat.RGBA32F)
            .usage(USAGE.COLOR_ATTACHMENT | USAGE.SAMPLEABLE).build(this.engine);
        const depth = F.Texture.Builder().width(w).height(h).levels(1)
            .sampler(F.Texture$Sampler.SAMPLER_2D).format(F.Texture$InternalFormat.DEPTH32F)
            .usage(USAGE.DEPTH_ATTACHMENT).build(this.engine);
        const target = F.RenderTarget.Builder()
            .texture(F.RenderTarget$AttachmentPoint.COLOR, color)
            .texture(F.RenderTarget$AttachmentPoint.DEPTH, depth)
            .build(this.engine);
        const view = this.engine.createView();
        view.setScene(scene);
        view.setCamera(camera);
        view.setViewport([0, 0, w, h]);
        view.setRenderTarget(target);
        // No tone mapping, colour grading, dithering, FXAA, TAA, bloom or dynamic resolution: the
        // colour pass writes straight into the target (the web build binds no setDithering:
        // dithering is one of the post-processing passes turned off here). MSAA is off by default; so are SSAO,
        // screen-space reflections and shadows (a light's
        // castShadows is off by default: the README's sun casts none).
        view.setPostProcessingEnabled(false);
        view.setAntiAliasing(F.View$AntiAliasing.NONE);
        view.setAmbientOcclusion(F.View$AmbientOcclusion.NONE);
        view.setColorGrading(F.ColorGrading.Builder().toneMapping(F.ColorGrading$ToneMapping.LINEAR).build(this.engine));
        return { view, color, w, h, before };
    }

    /// The GL texture Filament made for `v`'s colour attachment (allocated lazily: after a frame).
    glTexture(v) {
        const found = this.state.textures.slice(v.before)
            .filter(t => t.format === this.gl.RGBA32F && t.w === v.w && t.h === v.h);
        if (found.length !== 1) {
            throw new Error(`${found.length} RGBA32F ${v.w}x${v.h} textures allocated for the render target`);
        }
        return found[0].tex;
    }

    /// Renders `v` until two frames in a row read back the same and the frame is not empty.
    async settle(v, maxFrames = 60) {
        let previous = null;
        for (let frame = 1; frame <= maxFrames; frame++) {
            await new Promise(r => setTimeout(r, 0));
            this.renderer.render(this.swapChain, v.view);
            this.engine.execute();
            const pixels = readTexture(this.gl, this.glTexture(v), v.w, v.h);
            let covered = 0;
            for (let i = 3; i < pixels.length; i += 4) {
                if (pixels[i] > 0) {
                    covered++;
                }
            }
            if (covered > 0 && sameFrame(previous, pixels)) {
                return { pixels, frames: frame, covered };
            }
            previous = pixels;
        }
        throw new Error(`no settled frame after ${maxFrames} frames`);
    }
}

async function renderSpheres(r, job, assetLoader, glb) {
    const F = Filament;
    const engine = r.engine;
    const scene = engine.createScene();
    const bundle = ktx1Bundle(await getBytes(job.ibl));
    const reflections = F.ktx1reader$createTexture(engine, bundle, false);
    const sh = job.sh
        ? parseShText(new TextDecoder().decode(await getBytes(job.sh)))
        : bundle.getMetadata('sh').split(/\s/, 27).map(parseFloat);
    const intensity = job.ibl_intensity ?? 1.0;
    const ibl = F.IndirectLight.Builder().reflections(reflections).irradianceSh(3, new Float32Array(sh))
        .intensity(intensity).build(engine);
    scene.setIndirectLight(ibl);

    const asset = assetLoader.createAsset(glb);
    await new Promise(done => asset.loadResources(done, null, null, 1));
    asset.releaseSourceData && asset.releaseSourceData();
    scene.addEntities(asset.getEntities());
    const sun = job.sun ? await runSunLines(job.sun, {}, { Filament: F, engine, scene }, translateSunLines) : null;
    // Geometric specular anti-aliasing (the ubershaders' `specularAntiAliasing : true`):
    // Filament widens each pixel's roughness by the screen-space variance of the normal,
    // alpha'^2 = alpha^2 + min(2 variance (|dn/dx|^2 + |dn/dy|^2), threshold^2). The job may pin
    // the two parameters ([variance, threshold]); the reference models the same term.
    if (job.specular_aa) {
        const [variance, threshold] = job.specular_aa;
        const rm = engine.getRenderableManager();
        for (const entity of asset.getRenderableEntities()) {
            const mi = rm.getMaterialInstanceAt(rm.getInstance(entity), 0);
            // MaterialInstance::setSpecularAntiAliasingVariance/Threshold (not bound in the web
            // build) set these parameters, the threshold squared.
            mi.setFloatParameter('_specularAntiAliasingVariance', variance);
            mi.setFloatParameter('_specularAntiAliasingThreshold', threshold * threshold);
        }
    }

    const camera = engine.createCamera(F.EntityManager.get().create());
    const halfW = Scene.VIEW_WIDTH / 2, halfH = Scene.VIEW_WIDTH * Scene.HEIGHT / Scene.WIDTH / 2;
    camera.setProjection(F.Camera$Projection.ORTHO, -halfW, halfW, -halfH, halfH, 1.0, 20.0);
    camera.lookAt([0, 0, Scene.CAMERA_Z], [0, 0, 0], [0, 1, 0]);
    // Exposure 1 / intensity: f/N, 1.2 N^2 / I seconds, ISO 100 (EV100 = log2(I / 1.2)); N grows with
    // I up to f/16 because Filament clamps the settings (ISO 10 to 204800, 1/25000 to 60 s, f/0.5
    // to f/64): ISO 100 / 30000 became ISO 10, exposure 0.1.
    const aperture = Math.min(Math.sqrt(intensity), 16);
    camera.setExposure(aperture, 1.2 * aperture ** 2 / intensity, 100.0);
    const v = r.view(scene, camera, Scene.WIDTH, Scene.HEIGHT);
    const result = await r.settle(v);
    // Filament's exposure 1 / (1.2 2^EV100), EV100 = log2(N^2 / t 100 / S) (Exposure.cpp).
    const ev100 = Math.log2(camera.getAperture() ** 2 / camera.getShutterSpeed() * 100 / camera.getSensitivity());
    return { result, sh, exposure: 1 / (1.2 * 2 ** ev100), levels: reflections.getLevels(engine), ibl_intensity: intensity, sun };
}

async function renderSky(r, job) {
    const F = Filament;
    const engine = r.engine;
    const scene = engine.createScene();
    const bundle = ktx1Bundle(await getBytes(job.sky));
    const tex = F.ktx1reader$createTexture(engine, bundle, false);
    // Filament's Skybox multiplies the cube by its intensity (default 30000, the same as
    // IndirectLight's: FSkybox); set it to 1 where the web build binds the builder's intensity().
    const builder = F.Skybox.Builder().environment(tex);
    let intensity = 30000;
    if (typeof builder.intensity === 'function') {
        builder.intensity(1.0);
        intensity = 1;
    }
    scene.setSkybox(builder.build(engine));
    const camera = engine.createCamera(F.EntityManager.get().create());
    camera.setProjectionFov(job.fov_deg, 1.0, 0.1, 10.0, F.Camera$Fov.VERTICAL);
    camera.lookAt([0, 0, 0], job.forward, job.up);
    camera.setExposure(1.0, 1.2, 100.0);
    const v = r.view(scene, camera, job.size, job.size);
    return { result: await r.settle(v), intensity };
}

async function main() {
    const job = await getJson('job.json');
    const report = { filament: null, renders: [], ktx1: {}, ktx2: {}, errors: [] };
    report.filament = (await (await fetch('node_modules/filament/package.json')).json()).version;
    await new Promise(ready => Filament.init([], ready));
    const canvas = document.getElementById('canvas');
    const r = new Renderer(canvas);
    report.webgl = { version: r.gl.getParameter(r.gl.VERSION), renderer: r.gl.getParameter(r.gl.RENDERER) };
    await post('scene.json', JSON.stringify(Scene.geometryJson(1.0, 1.0), null, 2));

    for (const path of job.ktx1 || []) {
        try {
            report.ktx1[path] = ktx1Report(await getBytes(path));
        } catch (e) {
            report.errors.push(`${path}: ${e}`);
        }
    }
    for (const path of job.ktx2 || []) {
        try {
            report.ktx2[path] = ktx2Report(await getBytes(path));
        } catch (e) {
            report.errors.push(`${path}: ${e}`);
        }
    }

    const assetLoader = r.engine.createAssetLoader();
    const glb = Scene.spheresGlb();
    for (const entry of job.renders) {
        try {
            const out = entry.kind === 'sky' ? await renderSky(r, entry) : await renderSpheres(r, entry, assetLoader, glb);
            await post(entry.name + '.f32', out.result.pixels.buffer);
            report.renders.push({ name: entry.name, frames: out.result.frames, covered: out.result.covered, sh: out.sh || null, levels: out.levels || null, exposure: out.exposure || null, intensity: out.intensity || null, ibl_intensity: out.ibl_intensity || null, sun: out.sun || null });
            log(`${entry.name}: ${out.result.frames} frames`);
        } catch (e) {
            report.errors.push(`${entry.name}: ${e}\n${e.stack || ''}`);
            log(`${entry.name}: ${e}`);
        }
    }
    await post('shaders.txt', r.state.shaders.join('\n// ======== next shader ========\n'));
    await post('report.json', JSON.stringify(report, null, 1));
}

run(main);
