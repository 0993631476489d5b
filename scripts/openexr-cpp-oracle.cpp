// Expected values for the luminance/chroma files of tests/exr_conformance.rs, computed ONCE with
// OpenEXR's own C++ library (`RgbaInputFile`, which reconstructs subsampled chroma), so that CI
// compares without the oracle installed. OpenEXR 3.1.5 (Debian's libopenexr-dev) was used:
//
//     apt-get install libopenexr-dev g++ pkg-config
//     g++ -O2 -o /tmp/openexr-oracle scripts/openexr-cpp-oracle.cpp $(pkg-config --cflags --libs OpenEXR)
//     /tmp/openexr-oracle --write tests/data/openexr/Rec709.exr tests/data/openexr/yc
//     /tmp/openexr-oracle --write-deep-multipart tests/data/openexr/deep_then_flat.exr
//     /tmp/openexr-oracle tests/data/openexr/Rec709_YC.exr tests/data/openexr/XYZ_YC.exr \
//         tests/data/openexr/yc/*.exr > tests/data/openexr/expected-yca.json
//
// `--write IN DIR` writes, with `RgbaOutputFile` and `WRITE_YC`, a 96x64 crop of IN (from pixel
// 300, 200: foliage and sky) in every compression OpenEXR has, as DIR/yc_<compression>.exr: the
// luminance/chroma layout through each of the exr crate's decompressors.
//
// `--write-deep-multipart OUT` writes a two-part file: part 0 "depth", deep scan lines (one
// float Z and a varying number of samples per pixel, ZIPS), part 1 "beauty", flat half RGB
// (ZIP) with R = x / 64, G = y / 32, B = (x + y) / 128 on 64x32 pixels (exact in half): a flat
// part behind a deep one.
//
// Per file: the data window's size; per channel R, G, B the mean (double, over finite values);
// the values at a 9x7 grid of pixels that includes the first and last rows and columns (where
// OpenEXR pads and clamps); and FNV-1a 64 of every pixel's R, G, B half bits in row order, so
// the test can check the whole image bit for bit from one number.
#include <ImfArray.h>
#include <ImfChannelList.h>
#include <ImfDeepFrameBuffer.h>
#include <ImfDeepScanLineOutputPart.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfMultiPartOutputFile.h>
#include <ImfOutputPart.h>
#include <ImfPartType.h>
#include <ImfRgbaFile.h>

#include <vector>

#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <string>

static int write_crops(const char *in, const char *dir) {
    Imf::RgbaInputFile src(in);
    Imath::Box2i dw = src.dataWindow();
    int w = dw.max.x - dw.min.x + 1, h = dw.max.y - dw.min.y + 1;
    Imf::Array2D<Imf::Rgba> px(h, w);
    src.setFrameBuffer(&px[0][0] - dw.min.x - dw.min.y * w, 1, w);
    src.readPixels(dw.min.y, dw.max.y);
    const int cw = 96, ch = 64, x0 = 300, y0 = 200;
    Imf::Array2D<Imf::Rgba> crop(ch, cw);
    for (int y = 0; y < ch; ++y)
        for (int x = 0; x < cw; ++x) crop[y][x] = px[y0 + y][x0 + x];
    const struct {
        Imf::Compression c;
        const char *name;
    } all[] = {{Imf::NO_COMPRESSION, "none"}, {Imf::RLE_COMPRESSION, "rle"},   {Imf::ZIPS_COMPRESSION, "zips"},
               {Imf::ZIP_COMPRESSION, "zip"},   {Imf::PIZ_COMPRESSION, "piz"},   {Imf::PXR24_COMPRESSION, "pxr24"},
               {Imf::B44_COMPRESSION, "b44"},   {Imf::B44A_COMPRESSION, "b44a"}, {Imf::DWAA_COMPRESSION, "dwaa"},
               {Imf::DWAB_COMPRESSION, "dwab"}};
    for (const auto &c : all) {
        char path[4096];
        std::snprintf(path, sizeof path, "%s/yc_%s.exr", dir, c.name);
        Imf::Header header(cw, ch);
        header.compression() = c.c;
        Imf::RgbaOutputFile out(path, header, Imf::WRITE_YC);
        out.setFrameBuffer(&crop[0][0], 1, cw);
        out.writePixels(ch);
    }
    return 0;
}

static int write_deep_multipart(const char *out) {
    const int w = 64, h = 32;
    Imf::Header deep(w, h);
    deep.setName("depth");
    deep.setType(Imf::DEEPSCANLINE);
    deep.compression() = Imf::ZIPS_COMPRESSION;
    deep.channels().insert("Z", Imf::Channel(Imf::FLOAT));
    Imf::Header flat(w, h);
    flat.setName("beauty");
    flat.setType(Imf::SCANLINEIMAGE);
    flat.compression() = Imf::ZIP_COMPRESSION;
    for (const char *c : {"R", "G", "B"}) flat.channels().insert(c, Imf::Channel(Imf::HALF));
    std::vector<Imf::Header> headers = {deep, flat};
    Imf::MultiPartOutputFile file(out, headers.data(), 2);

    // Deep part: pixel (x, y) has (x + y) % 3 samples at depths 1, 2, ...
    Imf::Array2D<unsigned int> counts(h, w);
    Imf::Array2D<float *> zs(h, w);
    std::vector<float> storage;
    storage.reserve(w * h * 3);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            counts[y][x] = (x + y) % 3;
            zs[y][x] = storage.data() + storage.size();
            for (unsigned s = 0; s < counts[y][x]; ++s) storage.push_back(float(s + 1));
        }
    Imf::DeepScanLineOutputPart depth(file, 0);
    Imf::DeepFrameBuffer dfb;
    dfb.insertSampleCountSlice(
        Imf::Slice(Imf::UINT, (char *)&counts[0][0], sizeof(unsigned int), sizeof(unsigned int) * w));
    dfb.insert("Z", Imf::DeepSlice(Imf::FLOAT, (char *)&zs[0][0], sizeof(float *), sizeof(float *) * w, sizeof(float)));
    depth.setFrameBuffer(dfb);
    depth.writePixels(h);

    Imf::Array2D<half> r(h, w), g(h, w), b(h, w);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            r[y][x] = x / 64.0f;
            g[y][x] = y / 32.0f;
            b[y][x] = (x + y) / 128.0f;
        }
    Imf::OutputPart beauty(file, 1);
    Imf::FrameBuffer fb;
    fb.insert("R", Imf::Slice(Imf::HALF, (char *)&r[0][0], sizeof(half), sizeof(half) * w));
    fb.insert("G", Imf::Slice(Imf::HALF, (char *)&g[0][0], sizeof(half), sizeof(half) * w));
    fb.insert("B", Imf::Slice(Imf::HALF, (char *)&b[0][0], sizeof(half), sizeof(half) * w));
    beauty.setFrameBuffer(fb);
    beauty.writePixels(h);
    return 0;
}

int main(int argc, char **argv) {
    if (argc == 3 && std::string(argv[1]) == "--write-deep-multipart") return write_deep_multipart(argv[2]);
    if (argc == 4 && std::string(argv[1]) == "--write") return write_crops(argv[2], argv[3]);
    std::printf("{\n \"oracle\": \"OpenEXR %s RgbaInputFile\",\n \"files\": {", OPENEXR_VERSION_STRING);
    for (int f = 1; f < argc; ++f) {
        Imf::RgbaInputFile file(argv[f]);
        Imath::Box2i dw = file.dataWindow();
        int w = dw.max.x - dw.min.x + 1, h = dw.max.y - dw.min.y + 1;
        Imf::Array2D<Imf::Rgba> px(h, w);
        file.setFrameBuffer(&px[0][0] - dw.min.x - dw.min.y * w, 1, w);
        file.readPixels(dw.min.y, dw.max.y);

        uint64_t hash = 1469598103934665603ull;
        double sum[3] = {0, 0, 0};
        long count[3] = {0, 0, 0};
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                const Imf::Rgba &p = px[y][x];
                const half c[3] = {p.r, p.g, p.b};
                for (int k = 0; k < 3; ++k) {
                    uint16_t bits = c[k].bits();
                    for (int b = 0; b < 2; ++b) {
                        hash ^= (bits >> (8 * b)) & 0xff;
                        hash *= 1099511628211ull;
                    }
                    float v = c[k];
                    if (std::isfinite(v)) {
                        sum[k] += v;
                        ++count[k];
                    }
                }
            }

        const char *base = argv[f];
        for (const char *s = argv[f]; *s; ++s)
            if (*s == '/') base = s + 1;
        std::printf("%s\n  \"%s\": {\n   \"size\": [%d, %d],\n   \"fnv1a64_rgb_half_bits\": \"%016" PRIx64 "\",\n",
                    f > 1 ? "," : "", base, w, h, hash);
        std::printf("   \"mean\": [%.17g, %.17g, %.17g],\n   \"samples\": [", sum[0] / count[0], sum[1] / count[1],
                    sum[2] / count[2]);
        bool first = true;
        for (int j = 0; j < 7; ++j)
            for (int i = 0; i < 9; ++i) {
                int x = (int)std::lround(i * (w - 1) / 8.0), y = (int)std::lround(j * (h - 1) / 6.0);
                const Imf::Rgba &p = px[y][x];
                std::printf("%s\n    [%d, %d, %.9g, %.9g, %.9g]", first ? "" : ",", x, y, (float)p.r, (float)p.g,
                            (float)p.b);
                first = false;
            }
        std::printf("\n   ]\n  }");
    }
    std::printf("\n }\n}\n");
    return 0;
}
