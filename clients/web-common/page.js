// What every render page of the engine render tests shares (clients/filament-web/render.js,
// clients/three-web/render.js, clients/khronos-web/render.js): the page's log, the test's folder (GET ../work/PATH: job.json,
// the bakes), the results (POST ../result/NAME), and the page's end: `data-status` on the body is
// "done" once main() has posted its report.json, or "failed" after the error is posted as
// `{ "fatal", "stack" }` in its place. Served at /common/ beside each client's /app/ by the
// tests' loopback server (tests/common/server.rs) and scripts/serve-web-client.py.

const logEl = document.getElementById('log');

export function log(msg) {
    logEl.textContent += msg + '\n';
    console.log(msg);
}

export async function post(name, body) {
    const r = await fetch('../result/' + name, { method: 'POST', body });
    if (!r.ok) {
        throw new Error(`POST ${name}: ${r.status}`);
    }
}

async function getWork(path) {
    const r = await fetch('../work/' + path);
    if (!r.ok) {
        throw new Error(`GET ${path}: ${r.status}`);
    }
    return r;
}

export async function getBytes(path) {
    return new Uint8Array(await (await getWork(path)).arrayBuffer());
}

export async function getJson(path) {
    return (await getWork(path)).json();
}

/// Runs `main` (which posts report.json) and marks the page's end.
export function run(main) {
    main().then(() => {
        document.body.dataset.status = 'done';
    }, async e => {
        log('failed: ' + e + '\n' + (e.stack || ''));
        try {
            await post('report.json', JSON.stringify({ fatal: String(e), stack: e.stack || '' }));
        } catch (_) {
            // the test times out and reports the page's silence
        }
        document.body.dataset.status = 'failed';
    });
}

/// The text under "The sun:" at the end of the bake's README.txt at ../work/`readme`, as written
/// (an error when there is none): what runSunLines runs, and what a page whose sun is data rather
/// than code (the Khronos page's KHR_lights_punctual snippet) reads.
export async function readSunLines(readme) {
    const text = new TextDecoder().decode(await getBytes(readme));
    const at = text.indexOf('\nThe sun:\n');
    if (at < 0) {
        throw new Error(`${readme}: no "The sun:" lines`);
    }
    return text.slice(at + '\nThe sun:\n'.length);
}

/// The engine code under "The sun:" at the end of a bake's README.txt (`hdrflow bake --sun
/// extract`: the lines that add the extracted sun as the engine's directional light), fetched from
/// ../work/`readme` and run as the user's module runs it, so that the render tests check the lines
/// users read (tests/common/sun_lines.rs): each `import` line is bound to the module the page
/// imported under that name (`modules`: specifier to the module's namespace or the names the lines
/// import from it), and the rest runs as the
/// body of an async function of `scope`'s names (the engine's namespace and `scene` or `app`).
/// A README without the sun's lines, or a module the page did not give, is an error. `translate`
/// turns lines in another language into JavaScript first (the Filament page's C++: its
/// sun_lines.js, which throws on what it does not know); the JavaScript run is returned.
export async function runSunLines(readme, modules, scope, translate = lines => lines) {
    const body = translate(await readSunLines(readme)).split('\n').map(line => {
        const m = line.match(/^import\s+(.+?)\s+from\s+'([^']+)';?\s*$/);
        if (!m) {
            return line;
        }
        if (!(m[2] in modules)) {
            throw new Error(`${readme}: the sun's lines import ${m[2]}, which the page does not give`);
        }
        const binding = m[1].startsWith('* as ') ? m[1].slice(5) : m[1];
        const missing = binding.startsWith('{') ? binding.slice(1, -1).split(',').map(n => n.trim()).filter(n => n && !(n in modules[m[2]])) : [];
        if (missing.length) {
            throw new Error(`${readme}: the sun's lines import ${missing.join(', ')} from ${m[2]}, which the page does not give`);
        }
        return `const ${binding} = __modules[${JSON.stringify(m[2])}];`;
    }).join('\n');
    const AsyncFunction = (async () => {}).constructor;
    await new AsyncFunction('__modules', ...Object.keys(scope), body)(modules, ...Object.values(scope));
    return body;
}
