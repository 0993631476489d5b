// The Filament README's sun lines (src/ibl_presets/filament.rs, `sun_code`) are C++; filament.js is
// Emscripten's binding of the same API, so the page runs them by translating them token by token
// into the binding's JavaScript (tests/filament_render.rs, issue 36). The translator is strict:
// a token, name, method or construct it does not know is an error naming the line, so that what
// runs is the lines users read and not a rewrite of them. It knows:
//
//   utils::Entity NAME = ...;                  const NAME = ...;
//   utils::EntityManager::get()                Filament.EntityManager.get()
//   LightManager::Builder(...)                 Filament.LightManager.Builder(...)
//   LightManager::Type::SUN (DIRECTIONAL)      Filament.LightManager$Type.SUN
//   .color .intensity .direction .sunAngularRadius .build .create .addEntity (the binding's names)
//   { a, b, c } (a braced argument)            [a, b, c] (the binding's float3)
//   30000.0f                                   30000.0
//   *engine, scene->                           engine, scene. (the loading code's pointers)
//   // comments                                kept
//
// `engine` and `scene` are the README's loading code's `Engine*` and `Scene*`: used without `*`
// or `->` they are a C++ type error, and an error here too.

/// The C++ names the lines may use, qualified as written, and their JavaScript.
const NAMES = new Map([
    ['utils::EntityManager::get', 'Filament.EntityManager.get'],
    ['LightManager::Builder', 'Filament.LightManager.Builder'],
    ['LightManager::Type::SUN', 'Filament.LightManager$Type.SUN'],
    ['LightManager::Type::DIRECTIONAL', 'Filament.LightManager$Type.DIRECTIONAL'],
]);

/// The methods the lines may call: each bound under the same name (filament.d.ts,
/// LightManager$Builder, EntityManager, Scene).
const METHODS = new Set(['color', 'intensity', 'direction', 'sunAngularRadius', 'build', 'create', 'addEntity']);

/// The declarations the lines may make: the type's C++ name.
const TYPES = new Set(['utils::Entity']);

/// The loading code's pointers, in scope where the sun's lines go.
const POINTERS = new Set(['engine', 'scene']);

const TOKEN = /\s+|\/\/.*|(?<num>(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?f?)|(?<name>[A-Za-z_]\w*(?:::[A-Za-z_]\w*)*)|(?<punct>->|[(){},;.*=-])/y;

/// `cpp`, the README's text under "The sun:", as JavaScript for filament.js (scope: `Filament`,
/// `engine`, `scene`); throws on anything it does not know.
export function translateSunLines(cpp) {
    const declared = new Set();
    const out = [];
    const lines = cpp.split('\n');
    // The previous significant token across lines (statements span several), and the open
    // braces (a braced argument list, translated to an array).
    let previous = null;
    let braces = 0;
    for (let n = 0; n < lines.length; n++) {
        const line = lines[n];
        const fail = why => {
            throw new Error(`the sun's C++ line ${n + 1} ${JSON.stringify(line)}: ${why}`);
        };
        const tokens = [];
        TOKEN.lastIndex = 0;
        while (TOKEN.lastIndex < line.length) {
            const at = TOKEN.lastIndex;
            const m = TOKEN.exec(line);
            if (!m) {
                fail(`unknown text at column ${at + 1}`);
            }
            if (m[0].startsWith('//')) {
                tokens.push({ comment: m[0] });
            } else if (m.groups.num || m.groups.name || m.groups.punct) {
                tokens.push(m.groups);
            }
        }
        let js = '';
        for (let i = 0; i < tokens.length; i++) {
            const t = tokens[i];
            const next = tokens[i + 1] || {};
            if (t.comment) {
                js += (js ? ' ' : '') + t.comment;
                continue;
            }
            // A name or number right after a name, a number or `)` is a C++ syntax error (a
            // missing `;` or operator) that JavaScript's semicolon insertion would hide.
            const operand = t.num || t.name;
            if (operand && previous !== null && previous !== '.' && previous !== '->' && !/^[;(,={*-]$/.test(previous)) {
                fail(`${operand} after ${previous}: a missing ; or operator`);
            }
            if (t.num) {
                js += t.num.replace(/f$/, '');
            } else if (t.name && TYPES.has(t.name)) {
                // A declaration: the statement's first token, then a new name and `=`.
                const name = next.name;
                if (previous !== null && previous !== ';' || !name || name.includes('::') || tokens[i + 2]?.punct !== '=') {
                    fail(`${t.name} is only known as a declaration "${t.name} name = ..."`);
                }
                if (declared.has(name) || POINTERS.has(name)) {
                    fail(`${name} declared twice`);
                }
                declared.add(name);
                js += `const ${name} = `;
                i += 2;
                previous = '=';
                continue;
            } else if (t.name && NAMES.has(t.name)) {
                js += NAMES.get(t.name);
            } else if (t.name && (previous === '.' || previous === '->')) {
                if (!METHODS.has(t.name)) {
                    fail(`method ${t.name} is not one the translator knows`);
                }
                js += t.name;
            } else if (t.name && POINTERS.has(t.name)) {
                if (previous !== '*' && next.punct !== '->') {
                    fail(`${t.name} is a pointer (the loading code's *${t.name}, ${t.name}->): used as a value`);
                }
                js += t.name;
            } else if (t.name && declared.has(t.name)) {
                js += t.name;
            } else if (t.name) {
                fail(`unknown name ${t.name}`);
            } else if (t.punct === '*' && POINTERS.has(next.name)) {
                // The dereference `*engine`: the binding takes the object itself.
                if (previous !== '(' && previous !== ',') {
                    fail('a dereference outside an argument list');
                }
            } else if (t.punct === '->') {
                if (!POINTERS.has(previous)) {
                    fail('-> on something that is not the loading code\'s pointer');
                }
                js += '.';
            } else if (t.punct === '{') {
                if (previous !== '(' && previous !== ',') {
                    fail('a brace outside an argument list');
                }
                braces++;
                js += '[';
            } else if (t.punct === '}') {
                if (braces === 0) {
                    fail('an unmatched }');
                }
                braces--;
                js += ']';
            } else if (t.punct === '=') {
                fail('an assignment that is not a declaration');
            } else {
                js += t.punct === ',' ? ', ' : t.punct === '*' ? ' * ' : t.punct;
            }
            previous = t.name || t.num || t.punct;
        }
        out.push(line.match(/^\s*/)[0] + js);
    }
    if (braces !== 0 || (previous !== null && previous !== ';')) {
        throw new Error(`the sun's C++ lines end inside a statement: ${JSON.stringify(cpp)}`);
    }
    return out.join('\n');
}
