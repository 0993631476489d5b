// Renders the job of tests/three_render.rs with three.js (npm `three`, pinned in package.json) in
// WebGL2, and reads the frames back as 32-bit floats.
//
// The job (GET ../work/job.json) lists renders; paths are relative to ../work/:
//   { "renders": [
//       { "name", "kind": "sky", "map": "x_three.hdr", "forward": [x, y, z], "fov_deg", "size" }
//     | { "name", "kind": "probe", "sh": "x_sh.json", "material": "standard" | "lambert",
//         "size", "view_width", "radius", "sun"? }
//     | { "name", "kind": "spheres", "map": "x_three.hdr", "spheres": [{ "name", "centre",
//         "radius", "metallic", "roughness" }], "width", "height", "view_width", "sun"? } ] }
// Results are POSTed to ../result/NAME: NAME.f32 (RGBA f32 rows, top row first) per render, and
// last report.json (three's revision, the WebGL renderer, per render what was loaded and handed
// to three; errors).
//
// Every render writes linear radiance: the renderer's output colour space is linear sRGB with no
// tone mapping, and the frame goes into an RGBA32F WebGLRenderTarget (whose texture has no colour
// space: three converts and tone-maps only for the canvas), read with readRenderTargetPixels as
// floats (EXT_color_buffer_float). HDR files load with HDRLoader as 32-bit floats (its default
// is half floats), in linear sRGB, the working colour space: no conversion anywhere.
//
// - sky: the map as `scene.background` with EquirectangularReflectionMapping (three turns it
//   into a cube render target, `equirectUv`), seen by a PerspectiveCamera at the origin looking
//   along `forward`, +Y up, `fov_deg` vertical, square frame.
// - probe: one sphere at the origin seen by an orthographic camera on +Z looking down -Z (view
//   vector +Z at every pixel), lit only by `new THREE.LightProbe(new
//   THREE.SphericalHarmonics3().fromArray(json.coefficients.flat()))` as the preset's loading
//   code builds it (the JSON fetched as it fetches it, without page.js's status check: a missing
//   file fails as JSON that does not parse); white MeshStandardMaterial (roughness 1, metalness 0)
//   or MeshLambertMaterial.
//   `"sh": "furnace"` gives the probe of a constant radiance 1 (L00 = 2 sqrt(pi)).
// - spheres: the same camera over a row of white MeshStandardMaterial spheres lit only by
//   `scene.environment` = the map (three's own PMREMGenerator prefilters it).
// - probe and spheres with `"sun": "x/README.txt"`: the sun's lines of that README (a `--sun
//   extract` bake) run as they are in the same module (page.js, `runSunLines`), with `THREE` and
//   the render's `scene`: the sun added as the README adds it.

import * as THREE from 'three';
import { HDRLoader } from 'three/addons/loaders/HDRLoader.js';
import { getJson, log, post, run, runSunLines } from '../common/page.js';

// The lines that load the files are those of the README.txt hdrflow bake writes
// (src/ibl_presets/three.rs, `loading_code`; tests/bake.rs checks that each is a line here).
async function loadMap(path) {
    const mapUrl = '../work/' + path;
    const texture = await new HDRLoader().setDataType(THREE.FloatType).loadAsync(mapUrl);
    texture.mapping = THREE.EquirectangularReflectionMapping;
    return texture;
}

/// Renders `scene` through `camera` into a new RGBA32F target of w x h, twice (the second frame
/// must equal the first: nothing is left to compile or convert), and returns its pixels, top row
/// first.
function renderFloat(renderer, scene, camera, w, h) {
    const target = new THREE.WebGLRenderTarget(w, h, {
        type: THREE.FloatType,
        format: THREE.RGBAFormat,
        minFilter: THREE.NearestFilter,
        magFilter: THREE.NearestFilter,
        depthBuffer: true,
        samples: 0,
    });
    const frames = [];
    for (let k = 0; k < 2; k++) {
        renderer.setRenderTarget(target);
        renderer.setClearColor(0x000000, 0);
        renderer.clear();
        renderer.render(scene, camera);
        const bottomUp = new Float32Array(w * h * 4);
        renderer.readRenderTargetPixels(target, 0, 0, w, h, bottomUp);
        frames.push(bottomUp);
    }
    renderer.setRenderTarget(null);
    target.dispose();
    const [a, b] = frames;
    const stable = a.every((v, i) => v === b[i] || (Number.isNaN(v) && Number.isNaN(b[i])));
    const out = new Float32Array(w * h * 4);
    for (let y = 0; y < h; y++) {
        out.set(b.subarray((h - 1 - y) * w * 4, (h - y) * w * 4), y * w * 4);
    }
    return { pixels: out, stable };
}

function orthographic(viewWidth, w, h) {
    const halfW = viewWidth / 2, halfH = viewWidth * h / w / 2;
    const camera = new THREE.OrthographicCamera(-halfW, halfW, halfH, -halfH, 0.1, 100);
    camera.position.set(0, 0, 10);
    camera.lookAt(0, 0, 0);
    return camera;
}

async function renderSky(renderer, job) {
    const texture = await loadMap(job.map);
    const scene = new THREE.Scene();
    scene.background = texture;
    const camera = new THREE.PerspectiveCamera(job.fov_deg, 1, 0.1, 10);
    camera.position.set(0, 0, 0);
    camera.up.set(0, 1, 0);
    camera.lookAt(...job.forward);
    const out = renderFloat(renderer, scene, camera, job.size, job.size);
    texture.dispose();
    const image = texture.image;
    return { ...out, map: { width: image.width, height: image.height, type: texture.type } };
}

async function renderProbe(renderer, job) {
    const scene = new THREE.Scene();
    let frame = null;
    if (job.sh === 'furnace') {
        const coefficients = [2 * Math.sqrt(Math.PI), 2 * Math.sqrt(Math.PI), 2 * Math.sqrt(Math.PI)].concat(new Array(24).fill(0));
        scene.add(new THREE.LightProbe(new THREE.SphericalHarmonics3().fromArray(coefficients)));
    } else {
        const shUrl = '../work/' + job.sh;
        const json = await (await fetch(shUrl)).json();
        frame = json.frame || null;
        if (json.coefficients.flat().length !== 27) {
            throw new Error(`${job.sh}: ${json.coefficients.flat().length} numbers, not 27`);
        }
        scene.add(new THREE.LightProbe(new THREE.SphericalHarmonics3().fromArray(json.coefficients.flat())));
    }
    const probe = scene.children[0];
    const sun = job.sun ? await runSunLines(job.sun, { three: THREE }, { THREE, scene }) : null;
    const white = new THREE.Color(1, 1, 1);
    const material = job.material === 'lambert'
        ? new THREE.MeshLambertMaterial({ color: white })
        : new THREE.MeshStandardMaterial({ color: white, roughness: 1, metalness: 0 });
    const sphere = new THREE.Mesh(new THREE.SphereGeometry(job.radius, 256, 128), material);
    scene.add(sphere);
    const out = renderFloat(renderer, scene, orthographic(job.view_width, job.size, job.size), job.size, job.size);
    return { ...out, sh: Array.from(probe.sh.toArray()), frame, material: material.type, sun };
}

async function renderSpheres(renderer, job) {
    const texture = await loadMap(job.map);
    const scene = new THREE.Scene();
    scene.environment = texture;
    const sun = job.sun ? await runSunLines(job.sun, { three: THREE }, { THREE, scene }) : null;
    const geometry = new THREE.SphereGeometry(1, 256, 128);
    for (const s of job.spheres) {
        const material = new THREE.MeshStandardMaterial({ color: 0xffffff, roughness: s.roughness, metalness: s.metallic });
        const mesh = new THREE.Mesh(geometry, material);
        mesh.position.set(...s.centre);
        mesh.scale.setScalar(s.radius);
        scene.add(mesh);
    }
    const out = renderFloat(renderer, scene, orthographic(job.view_width, job.width, job.height), job.width, job.height);
    texture.dispose();
    return { ...out, sun };
}

async function main() {
    const job = await getJson('job.json');
    const report = { three: THREE.REVISION, renders: [], errors: [] };
    report.package = (await (await fetch('node_modules/three/package.json')).json()).version;
    const canvas = document.getElementById('canvas');
    const renderer = new THREE.WebGLRenderer({ canvas, antialias: false, alpha: false });
    renderer.outputColorSpace = THREE.LinearSRGBColorSpace;
    renderer.toneMapping = THREE.NoToneMapping;
    const gl = renderer.getContext();
    report.webgl = { version: gl.getParameter(gl.VERSION), renderer: gl.getParameter(gl.RENDERER) };
    report.extensions = ['EXT_color_buffer_float', 'OES_texture_float_linear'].filter(e => gl.getExtension(e));
    const kinds = { sky: renderSky, probe: renderProbe, spheres: renderSpheres };
    for (const entry of job.renders) {
        try {
            const start = performance.now();
            const out = await kinds[entry.kind](renderer, entry);
            await post(entry.name + '.f32', out.pixels.buffer);
            const { pixels, ...rest } = out;
            report.renders.push({ name: entry.name, ms: performance.now() - start, ...rest });
            log(`${entry.name}: ${(performance.now() - start).toFixed(0)} ms`);
        } catch (e) {
            report.errors.push(`${entry.name}: ${e}\n${e.stack || ''}`);
            log(`${entry.name}: ${e}`);
        }
    }
    await post('report.json', JSON.stringify(report, null, 1));
}

run(main);
