// Renders the job of tests/playcanvas_render.rs with PlayCanvas (npm `playcanvas`, pinned in
// package.json) in WebGL2, and reads the frames back as 32-bit floats.
//
// The job (GET ../work/job.json) lists renders; paths are relative to ../work/:
//   { "renders": [
//       { "name", "kind": "spheres", "atlas": "good/test_envAtlas.png", "sky": "good/test_skybox.png", "own"?, "sun"? }
//     | { "name", "kind": "sky", "atlas", "sky", "forward": [x, y, z], "fov_deg", "size" } ] }
// Results are POSTed to ../result/NAME: NAME.f32 (RGBA f32 rows, top row first) per render,
// scene.json (clients/web-common/scene.js's geometry), shaders.txt (the standard material's
// fragment shader PlayCanvas compiled) and last report.json (the package's version, the WebGL
// renderer, per render what was loaded and whether two frames agree; errors).
//
// Every render writes linear radiance: the camera's tone mapping is TONEMAP_LINEAR at the scene's
// exposure 1 and its gamma GAMMA_NONE, into an RGBA32F render target read back with readPixels.
//
// Directions: PlayCanvas' world is right-handed, +Y up, as hdrflow's: the page's directions are
// used as they are.
//
// - spheres: the six spheres of scene.js seen by an orthographic camera on +Z looking down -Z, lit
//   only by app.scene.envAtlas, loaded as the README's lines load it (with `own`, the atlas
//   PlayCanvas' EnvLighting.generateAtlas makes from the skybox PNG instead, for comparison). Metal spheres: a
//   StandardMaterial with no diffuse, specular white and no Fresnel (FRESNEL_NONE), gloss 1 -
//   roughness, so each pixel is the atlas' reflection itself; the diffuse sphere: diffuse white,
//   specular black, so each pixel is the atlas' ambient. With `"sun": "x/README.txt"`, the sun's
//   lines of that README (a `--sun extract` bake) run as they are (page.js, `runSunLines`, with
//   `pc` and `app`), and what they add to the scene is removed after the render.
// - sky: app.scene.skybox (EnvLighting.generateSkyboxCubemap of the skybox PNG) seen by a
//   perspective camera at the origin looking along `forward`, +Y up, `fov_deg` vertical, square.

import * as pc from 'playcanvas';
import { getJson, log, post, run, runSunLines } from '../common/page.js';
import * as Spheres from '../common/scene.js';

let app = null;

/// The lines that load the files are those of the README.txt hdrflow bake writes
/// (src/ibl_presets/playcanvas.rs, `loading_code`; tests/playcanvas_render.rs checks that each is a line here).
async function loadLighting(job) {
    const atlasUrl = '../work/' + job.atlas;
    const skyUrl = '../work/' + job.sky;
    const loadRgbp = (url) => new Promise((resolve, reject) => {
        const asset = new pc.Asset(url, 'texture', { url }, { type: 'rgbp', mipmaps: false });
        asset.once('load', (a) => resolve(a.resource));
        asset.once('error', reject);
        app.assets.add(asset);
        app.assets.load(asset);
    });
    app.scene.envAtlas = await loadRgbp(atlasUrl);
    app.scene.skybox = pc.EnvLighting.generateSkyboxCubemap(await loadRgbp(skyUrl));
    if (job.own) {
        // PlayCanvas' own prefiltering of the same panorama instead of the bake's atlas: the skybox
        // PNG is the map as PlayCanvas' equirect, which its EnvLighting filters at run time.
        const lightingSource = pc.EnvLighting.generateLightingSource(await loadRgbp(skyUrl));
        app.scene.envAtlas = pc.EnvLighting.generateAtlas(lightingSource);
    }
    const atlas = app.scene.envAtlas;
    return { width: atlas.width, height: atlas.height, type: atlas.type, encoding: atlas.encoding, skybox: app.scene.skybox.width };
}

/// Draws `n` frames by hand (the page never starts PlayCanvas' requestAnimationFrame loop, which
/// headless Chromium's virtual time does not wait for): what the loop's `tick` does per frame.
function frames(n) {
    for (let k = 0; k < n; k++) {
        app.update(0);
        app.render();
    }
}

/// Renders through `cameraEntity` into a new RGBA32F target of w x h twice (the second frame must
/// equal the first) and returns its pixels, top row first.
async function renderFloat(cameraEntity, w, h) {
    const device = app.graphicsDevice;
    const texture = new pc.Texture(device, {
        width: w, height: h, format: pc.PIXELFORMAT_RGBA32F, mipmaps: false,
        minFilter: pc.FILTER_NEAREST, magFilter: pc.FILTER_NEAREST,
    });
    const target = new pc.RenderTarget({ colorBuffer: texture, depth: true });
    cameraEntity.camera.renderTarget = target;
    const gl = device.gl;
    const out = [];
    for (let k = 0; k < 2; k++) {
        frames(2);
        const buf = new Float32Array(w * h * 4);
        gl.bindFramebuffer(gl.FRAMEBUFFER, target.impl._glFrameBuffer);
        gl.readPixels(0, 0, w, h, gl.RGBA, gl.FLOAT, buf);
        gl.bindFramebuffer(gl.FRAMEBUFFER, null);
        out.push(buf);
    }
    const [a, b] = out;
    const stable = a.every((v, i) => v === b[i] || (Number.isNaN(v) && Number.isNaN(b[i])));
    const pixels = new Float32Array(w * h * 4);
    for (let y = 0; y < h; y++) {
        pixels.set(b.subarray((h - 1 - y) * w * 4, (h - y) * w * 4), y * w * 4);
    }
    cameraEntity.camera.renderTarget = null;
    target.destroy();
    texture.destroy();
    return { pixels, stable };
}

function newCamera(settings) {
    const camera = new pc.Entity('camera');
    camera.addComponent('camera', {
        clearColor: new pc.Color(0, 0, 0, 0),
        toneMapping: pc.TONEMAP_LINEAR,
        gammaCorrection: pc.GAMMA_NONE,
        aspectRatioMode: pc.ASPECT_MANUAL,
        aspectRatio: 1,
        nearClip: 0.1,
        farClip: 100,
        ...settings,
    });
    app.root.addChild(camera);
    return camera;
}

function material(s) {
    const m = new pc.StandardMaterial();
    m.useMetalness = false;
    if (s.metallic === 1) {
        m.diffuse = new pc.Color(0, 0, 0);
        m.specular = new pc.Color(1, 1, 1);
        m.fresnelModel = pc.FRESNEL_NONE;
        m.gloss = 1 - s.perceptual_roughness;
    } else {
        m.diffuse = new pc.Color(1, 1, 1);
        m.specular = new pc.Color(0, 0, 0);
        m.gloss = 0;
    }
    m.update();
    return m;
}

async function renderSpheres(job) {
    const loaded = await loadLighting(job);
    const before = new Set(app.root.children);
    const sun = job.sun ? await runSunLines(job.sun, { playcanvas: pc }, { pc, app }) : null;
    const added = app.root.children.filter(e => !before.has(e));
    const device = app.graphicsDevice;
    const mesh = pc.Mesh.fromGeometry(device, new pc.SphereGeometry({ radius: Spheres.RADIUS, latitudeBands: 128, longitudeBands: 256 }));
    const entities = Spheres.SPHERES.map((s, k) => {
        const e = new pc.Entity(s.name);
        const m = material(s);
        e.addComponent('render', { meshInstances: [new pc.MeshInstance(mesh, m)] });
        e.setPosition(Spheres.centreX(k), 0, 0);
        app.root.addChild(e);
        return e;
    });
    const halfH = Spheres.VIEW_WIDTH * Spheres.HEIGHT / Spheres.WIDTH / 2;
    const camera = newCamera({
        projection: pc.PROJECTION_ORTHOGRAPHIC,
        orthoHeight: halfH,
        aspectRatio: Spheres.WIDTH / Spheres.HEIGHT,
    });
    camera.setPosition(0, 0, Spheres.CAMERA_Z);
    camera.lookAt(0, 0, 0);
    const out = await renderFloat(camera, Spheres.WIDTH, Spheres.HEIGHT);
    const mi = entities[1].render.meshInstances[0];
    const variants = mi.material.variants ? [...mi.material.variants.values()] : [];
    const shader = variants.map(s => s.definition?.fshader || '').join('\n');
    entities.forEach(e => e.destroy());
    added.forEach(e => e.destroy());
    camera.destroy();
    return { ...out, loaded, shader, sun };
}

async function renderSky(job) {
    const loaded = await loadLighting(job);
    const camera = newCamera({ fov: job.fov_deg, farClip: 5000 });
    camera.setPosition(0, 0, 0);
    camera.lookAt(...job.forward);
    const out = await renderFloat(camera, job.size, job.size);
    camera.destroy();
    return { ...out, loaded };
}

async function main() {
    const job = await getJson('job.json');
    const report = { renders: [], errors: [] };
    report.package = (await (await fetch('node_modules/playcanvas/package.json')).json()).version;
    const canvas = document.getElementById('canvas');
    app = new pc.Application(canvas, { graphicsDeviceOptions: { antialias: false, alpha: false, preserveDrawingBuffer: true, deviceTypes: ['webgl2'] } });
    // No frame loop: frames are drawn by hand (`frames`).
    app.requestAnimationFrame = () => {};
    app.start();
    const gl = app.graphicsDevice.gl;
    report.webgl = { version: app.graphicsDevice.isWebGL2 ? 2 : 1, renderer: gl.getParameter(gl.RENDERER), textureFloatRenderable: app.graphicsDevice.textureFloatRenderable };
    await post('scene.json', JSON.stringify(Spheres.geometryJson(1.0, 1.0), null, 2));
    const kinds = { spheres: renderSpheres, sky: renderSky };
    let shader = '';
    for (const entry of job.renders) {
        try {
            const start = performance.now();
            const out = await kinds[entry.kind](entry);
            await post(entry.name + '.f32', out.pixels.buffer);
            shader = out.shader || shader;
            report.renders.push({ name: entry.name, ms: performance.now() - start, stable: out.stable, loaded: out.loaded, sun: out.sun || null });
            log(`${entry.name}: ${(performance.now() - start).toFixed(0)} ms`);
        } catch (e) {
            report.errors.push(`${entry.name}: ${e}\n${e.stack || ''}`);
            log(`${entry.name}: ${e}`);
        }
    }
    await post('shaders.txt', shader);
    await post('report.json', JSON.stringify(report, null, 1));
}

run(main);
