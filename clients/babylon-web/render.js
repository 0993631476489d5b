// Renders the job of tests/babylon_render.rs and tests/gltf_render.rs with Babylon.js (npm
// `@babylonjs/core` and `@babylonjs/loaders`, pinned in package.json) in WebGL2, and reads the
// frames back as 32-bit floats.
//
// The job (GET ../work/job.json) lists renders; paths are relative to ../work/; each render's
// lighting is a .env ("env"), a glTF asset with an EXT_lights_image_based light ("gltf"), or a
// Radiance .hdr panorama that Babylon prefilters itself ("hdr": `HDRCubeTexture` with
// `prefilterOnLoad`, its GPU `HDRFiltering`, and the polynomial it computes from the cube; with
// "via_env", written by `CreateEnvTextureAsync` into a .env, POSTed as NAME.env, and that loaded):
//   { "renders": [
//       { "name", "kind": "spheres", "env": "good/test.env" | "gltf": "good/test.gltf" | "hdr": "map.hdr",
//         "via_env"?, "loader_gamma"?, "sun"? }
//     | { "name", "kind": "sky", "env" | "gltf", "forward": [x, y, z], "fov_deg", "size" } ] }
// Results are POSTed to ../result/NAME: NAME.f32 (RGBA f32 rows, top row first) per render,
// scene.json (clients/web-common/scene.js's geometry), shaders.txt (the PBR fragment shader Babylon
// compiled) and last report.json (the packages' versions, the WebGL renderer, per render what was
// loaded: the environment texture as Babylon made it, and whether two frames agree; errors).
//
// Every render writes linear radiance: the scene's image processing is left to a post process
// that is never run (`applyByPostProcess`, with `skipFinalColorClamp`, so the material writes its
// linear colour unclamped), into an RGBA32F RenderTargetTexture read back with readPixels.
//
// Directions: Babylon's default world is left-handed (+Z forward); the page's hdrflow directions
// (right-handed, -Z forward) are Babylon's with z negated: `babylon()`.
//
// - spheres: the six spheres of scene.js (PBRMaterial, white, Lambert diffuse: its `brdf`
//   default, EON, is Lambert at diffuse roughness 0 too; metallic 1 with roughness 0 to 1, and
//   the diffuse one with no specular at all, `metallicF0Factor` 0), seen by an orthographic camera
//   on hdrflow's +Z looking down -Z, lit only by `scene.environmentTexture` = the .env, or the
//   light of the .gltf (its glTF loader sets it), loaded as the README's lines load it. With
//   `"sun": "x/README.txt"`, the sun's lines of that README (a `--sun extract` bake) run as they
//   are (page.js, `runSunLines`, with the render's `scene`).
// - sky: `scene.createDefaultSkybox(env, true, 1000, 0)` (the .env's level 0) seen by a
//   perspective camera at the origin looking along `forward` (hdrflow's axes), +Y up, `fov_deg`
//   vertical, square frame.

import { CubeTexture } from '@babylonjs/core';
import { AppendSceneAsync } from '@babylonjs/core';
import '@babylonjs/loaders/glTF';
import { CreateEnvTextureAsync, HDRCubeTexture } from '@babylonjs/core';
import { Camera, Color3, Color4, Constants, DirectionalLight, Engine, FreeCamera, MeshBuilder, PBRMaterial, RenderTargetTexture, Scene, Vector3 } from '@babylonjs/core';
import { getJson, log, post, run, runSunLines } from '../common/page.js';
import * as Spheres from '../common/scene.js';

/// hdrflow's direction (x, y, z) as Babylon's left-handed world sees it.
function babylon([x, y, z]) {
    return new Vector3(x, y, -z);
}

// The lines that load the file are those of the README.txt hdrflow bake writes
// (src/ibl_presets/babylon.rs, `loading_code`; tests/babylon_render.rs checks that each is a line here).
async function loadEnv(scene, path) {
    const envUrl = '../work/' + path;
    scene.environmentTexture = CubeTexture.CreateFromPrefilteredData(envUrl, scene);
    return await whenLoaded(scene.environmentTexture, path);
}

// The lines that load the asset are those of the README.txt of `hdrflow bake --for gltf`
// (src/ibl_presets/gltf.rs, `loading_code`; tests/gltf_render.rs checks that each is a line here).
// The job's `loader_gamma` leaves the texture in gamma space, as the loader makes it (to show why
// the README's gammaSpace line is there: docs/src/guides/baking/gltf.md).
async function loadGltf(scene, path, loaderGamma) {
    const gltfUrl = '../work/' + path;
    await AppendSceneAsync(gltfUrl, scene);
    if (!scene.environmentTexture) {
        throw new Error(`${path}: the glTF loader set no scene.environmentTexture`);
    }
    if (!loaderGamma) {
        scene.environmentTexture.gammaSpace = false;
    }
    return await whenLoaded(scene.environmentTexture, path);
}

// Babylon's own prefiltering of a panorama, for the comparison of tests/babylon_render.rs: a cube
// of 256 (the size Babylon's tools give a .env), mipmapped, harmonics generated, linear, prefiltered
// on load (lodGenerationScale 0.8, as a .env).
// With `viaEnv`, Babylon's own way to a .env file: the prefiltered texture written by
// `CreateEnvTextureAsync` (RGBD PNG faces, the polynomial), then loaded as a .env is.
async function loadHdr(scene, path, viaEnv, name) {
    const hdr = new HDRCubeTexture('../work/' + path, scene, 256, false, true, false, true);
    scene.environmentTexture = hdr;
    const loaded = await whenLoaded(hdr, path);
    if (!viaEnv) {
        return loaded;
    }
    await scene.whenReadyAsync();
    const env = await CreateEnvTextureAsync(hdr);
    await post(name + '.env', env);
    hdr.dispose();
    const url = URL.createObjectURL(new Blob([env]));
    scene.environmentTexture = CubeTexture.CreateFromPrefilteredData(url, scene, '.env');
    return await whenLoaded(scene.environmentTexture, name + '.env');
}

/// The lighting of a render: its .env, its .gltf or its .hdr.
async function loadLighting(scene, job) {
    if (job.hdr) {
        return await loadHdr(scene, job.hdr, job.via_env, job.name);
    }
    return job.gltf ? await loadGltf(scene, job.gltf, job.loader_gamma) : await loadEnv(scene, job.env);
}

/// Waits for `texture` and says what Babylon made of it.
async function whenLoaded(texture, path) {
    await new Promise((resolve, reject) => {
        const timer = setTimeout(() => reject(new Error(`${path}: not loaded after 120 s`)), 120000);
        const done = () => {
            clearTimeout(timer);
            resolve();
        };
        if (texture.isReady()) {
            done();
        } else {
            texture.onLoadObservable.addOnce(done);
        }
    });
    const internal = texture.getInternalTexture();
    return {
        class: texture.getClassName(),
        gammaSpace: texture.gammaSpace,
        width: internal.width,
        type: internal.type,
        lodGenerationScale: texture.lodGenerationScale,
        lodGenerationOffset: texture.lodGenerationOffset,
        sphericalPolynomial: texture.sphericalPolynomial ? Object.fromEntries(
            ['x', 'y', 'z', 'xx', 'yy', 'zz', 'yz', 'zx', 'xy'].map(k => [k, texture.sphericalPolynomial[k].asArray()])) : null,
    };
}

function newScene(engine) {
    const scene = new Scene(engine);
    scene.clearColor = new Color4(0, 0, 0, 0);
    scene.imageProcessingConfiguration.applyByPostProcess = true;
    scene.imageProcessingConfiguration.skipFinalColorClamp = true;
    return scene;
}

/// Renders `scene`'s `meshes` through `camera` into a new RGBA32F target of w x h, twice (the
/// second frame must equal the first), and returns its pixels, top row first.
async function renderFloat(scene, camera, meshes, w, h) {
    const target = new RenderTargetTexture('frame', { width: w, height: h }, scene, {
        generateMipMaps: false,
        type: Constants.TEXTURETYPE_FLOAT,
        samplingMode: Constants.TEXTURE_NEAREST_SAMPLINGMODE,
        generateDepthBuffer: true,
    });
    target.renderList = meshes;
    target.activeCamera = camera;
    target.clearColor = new Color4(0, 0, 0, 0);
    scene.customRenderTargets.push(target);
    scene.activeCamera = camera;
    await scene.whenReadyAsync();
    const frames = [];
    for (let k = 0; k < 2; k++) {
        scene.render();
        frames.push(new Float32Array(await target.readPixels()));
    }
    const [a, b] = frames;
    const stable = a.every((v, i) => v === b[i] || (Number.isNaN(v) && Number.isNaN(b[i])));
    const out = new Float32Array(w * h * 4);
    for (let y = 0; y < h; y++) {
        out.set(b.subarray((h - 1 - y) * w * 4, (h - y) * w * 4), y * w * 4);
    }
    target.dispose();
    return { pixels: out, stable };
}

async function renderSpheres(engine, job) {
    const scene = newScene(engine);
    const loaded = await loadLighting(scene, job);
    // What the sun's lines import, by name: with a namespace import of the whole package the
    // own-prefiltering page of tests/babylon_render.rs ended without a report, twice (cause not
    // found), and passed with this.
    const core = { Color3, DirectionalLight, Vector3 };
    const sun = job.sun ? await runSunLines(job.sun, { '@babylonjs/core': core }, { scene }) : null;
    const meshes = Spheres.SPHERES.map((s, k) => {
        const mesh = MeshBuilder.CreateSphere(s.name, { diameter: 2 * Spheres.RADIUS, segments: 128 }, scene);
        mesh.position = babylon([Spheres.centreX(k), 0, 0]);
        const m = new PBRMaterial(s.name, scene);
        m.albedoColor = new Color3(1, 1, 1);
        m.metallic = s.metallic;
        m.roughness = s.perceptual_roughness;
        m.brdf.baseDiffuseModel = Constants.MATERIAL_DIFFUSE_MODEL_LAMBERT;
        if (s.metallic === 0) {
            m.metallicF0Factor = 0;
        }
        mesh.material = m;
        return mesh;
    });
    const camera = new FreeCamera('camera', babylon([0, 0, Spheres.CAMERA_Z]), scene);
    camera.mode = Camera.ORTHOGRAPHIC_CAMERA;
    const halfW = Spheres.VIEW_WIDTH / 2, halfH = Spheres.VIEW_WIDTH * Spheres.HEIGHT / Spheres.WIDTH / 2;
    Object.assign(camera, { orthoLeft: -halfW, orthoRight: halfW, orthoTop: halfH, orthoBottom: -halfH, minZ: 0.1, maxZ: 100 });
    camera.setTarget(Vector3.Zero());
    const out = await renderFloat(scene, camera, meshes, Spheres.WIDTH, Spheres.HEIGHT);
    const effect = meshes[1].material.getEffect();
    const shader = effect ? effect.fragmentSourceCode : '';
    scene.dispose();
    return { ...out, loaded, shader, sun };
}

async function renderSky(engine, job) {
    const scene = newScene(engine);
    const loaded = await loadLighting(scene, job);
    scene.createDefaultSkybox(scene.environmentTexture, true, 1000, 0);
    const camera = new FreeCamera('camera', Vector3.Zero(), scene);
    camera.fov = job.fov_deg * Math.PI / 180;
    camera.minZ = 0.1;
    camera.maxZ = 5000;
    camera.setTarget(babylon(job.forward));
    const out = await renderFloat(scene, camera, scene.meshes.slice(), job.size, job.size);
    scene.dispose();
    return { ...out, loaded };
}

async function main() {
    const job = await getJson('job.json');
    const report = { renders: [], errors: [] };
    report.package = (await (await fetch('node_modules/@babylonjs/core/package.json')).json()).version;
    report.loaders = (await (await fetch('node_modules/@babylonjs/loaders/package.json')).json()).version;
    const canvas = document.getElementById('canvas');
    const engine = new Engine(canvas, false, { preserveDrawingBuffer: true, premultipliedAlpha: false });
    const gl = engine._gl;
    report.webgl = { version: engine.webGLVersion, renderer: gl.getParameter(gl.RENDERER) };
    const caps = engine.getCaps();
    report.caps = { textureLOD: caps.textureLOD, textureHalfFloatRender: caps.textureHalfFloatRender, textureHalfFloatLinearFiltering: caps.textureHalfFloatLinearFiltering, textureFloatRender: caps.textureFloatRender };
    await post('scene.json', JSON.stringify(Spheres.geometryJson(1.0, 1.0), null, 2));
    const kinds = { spheres: renderSpheres, sky: renderSky };
    let shader = '';
    for (const entry of job.renders) {
        try {
            const start = performance.now();
            const out = await kinds[entry.kind](engine, entry);
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
