// Reads the `.ktx` and `.ktx2` files `Save` writes with the engines' own JavaScript readers, by
// hand (not in CI: it needs npm packages and node):
//
//   npm install --prefix /tmp/ktxjs filament@1.53.4 ktx-parse@2.0.0
//   NODE_PATH=/tmp/ktxjs/node_modules node scripts/check-ktx-files.cjs out/*.ktx out/*.ktx2
//
// `.ktx` (KTX 1.1): Filament's WebAssembly build parses it with its own `Ktx1Bundle` and maps
// the GL fields as `Ktx1Reader` does (internal format, pixel data format and type), then reads
// the `sh` key the way `createIblFromKtx1` does (27 floats split on whitespace). `.ktx2`:
// ktx-parse gives the header, the DFD samples and the level lengths. One JSON line per file;
// the exit code is 1 when a file fails to parse.
const fs = require('fs');

const files = process.argv.slice(2);
let failed = false;

function ktx2(file) {
    const { read } = require('ktx-parse');
    const c = read(new Uint8Array(fs.readFileSync(file)));
    const d = c.dataFormatDescriptor[0];
    return {
        vkFormat: c.vkFormat, typeSize: c.typeSize, size: [c.pixelWidth, c.pixelHeight], faces: c.faceCount,
        supercompression: c.supercompressionScheme, bytesPlane0: d.bytesPlane[0],
        samples: d.samples.map(s => [s.bitOffset, s.bitLength + 1, s.channelType, s.sampleLower, s.sampleUpper]),
        levels: c.levels.map(l => [l.levelData.byteLength, l.uncompressedByteLength]),
        keys: Object.keys(c.keyValue),
    };
}

function ktx1(M, file) {
    const bytes = new Uint8Array(fs.readFileSync(file));
    const bd = new M.driver$BufferDescriptor(bytes.byteLength);
    bd.getBytes().set(bytes);
    const k = new M.Ktx1Bundle(bd);
    const info = k.info();
    const sh = k.getMetadata('sh');
    const cubeBlobs = [];
    for (let l = 0; k.isCubemap() && l < k.getNumMipLevels(); l++) {
        const blob = k._getCubeBlob(l);
        cubeBlobs.push(blob.getBytes().length);
        blob.delete();
    }
    return {
        cube: k.isCubemap(), levels: k.getNumMipLevels(), size: [info.pixelWidth, info.pixelHeight],
        internalFormat: k.getInternalFormat(false).constructor.name,
        pixelDataFormat: k.getPixelDataFormat().constructor.name,
        pixelDataType: k.getPixelDataType().constructor.name,
        cubeBlobs, sh: sh ? sh.split(/\s/, 27).map(parseFloat) : null,
    };
}

function report(file, read) {
    try {
        console.log(JSON.stringify({ file, ...read() }));
    } catch (e) {
        failed = true;
        console.log(JSON.stringify({ file, error: String(e) }));
    }
}

const needFilament = files.some(f => f.endsWith('.ktx'));
const filament = needFilament ? require('filament')() : Promise.resolve(null);
filament.then(M => {
    for (const file of files) {
        report(file, file.endsWith('.ktx2') ? () => ktx2(file) : () => ktx1(M, file));
    }
    process.exit(failed ? 1 : 0);
});
