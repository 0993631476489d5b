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
