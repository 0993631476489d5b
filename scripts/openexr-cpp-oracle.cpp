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
//     scripts/fetch-openexr-images.sh            # (or --from-git-dir CLONE) -> tests/data/openexr-images
//     /tmp/openexr-oracle --channels tests/data/openexr-images $(cd tests/data/openexr-images && \
//         awk 'NF == 3 && $3 ~ /\.exr$/ {print $3}' ../../scripts/fetch-openexr-images.sh) \
//         > tests/data/openexr/expected-fetched.json
//     /tmp/openexr-oracle --info FILE...         # parts, compression, tiling, channels
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
#include <ImfInputPart.h>
#include <ImfMultiPartInputFile.h>
#include <ImfTileDescriptionAttribute.h>
#include <ImfMultiPartOutputFile.h>
#include <ImfOutputPart.h>
#include <ImfPartType.h>
#include <ImfRgbaFile.h>

#include <map>
#include <stdexcept>
#include <vector>

#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>
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

// ---------------------------------------------------------------------------------------------
// `--info FILE...`: per part its name, type, compression, tiling/levels, data window and
// channels (type, sampling): to pick the fetched set (tests/exr_fetched_conformance.rs).
//
// `--channels ROOT FILE...`: expected values for tests/exr_fetched_conformance.rs
// (-> tests/data/openexr/expected-fetched.json), FILE relative to ROOT. It mirrors what
// hdrflow's `decode_with(.., DecodeOptions { window: Data, colorspace: AsStored, .. })` returns,
// computed with OpenEXR's own readers:
// - the part: the first, in file order, that is not deep and has a channel R, G, B or Y, bare
//   or layer-prefixed (`choose_part` in src/formats/exr.rs);
// - a channel `C` is the channel named `C`, else the first (in name order) named `*.C` (`find`);
// - R, G or B present: R, G, B (a missing one is all 0) and A if present, each read as FLOAT
//   at full resolution through `MultiPartInputFile` + `InputPart` (level 0 of tiled parts);
// - else Y with 2x2-subsampled RY and BY: `RgbaInputFile`'s reconstruction (halves, as f32),
//   plus A (read as FLOAT); only part 0 (OpenEXR 3.1's `RgbaInputFile` reads part 0 only);
// - else Y alone: one channel Y.
// Per output channel: FNV-1a 64 of the f32 bits (little-endian bytes) in row order, the mean
// over finite values, and the values at a 5x5 grid including the borders.

static int info(int argc, char **argv) {
    for (int f = 2; f < argc; ++f) {
        Imf::MultiPartInputFile file(argv[f]);
        std::printf("%s: %d part(s)\n", argv[f], file.parts());
        for (int p = 0; p < file.parts(); ++p) {
            const Imf::Header &h = file.header(p);
            static const char *comp[] = {"none", "rle", "zips", "zip", "piz", "pxr24", "b44", "b44a", "dwaa", "dwab"};
            Imath::Box2i dw = h.dataWindow(), disp = h.displayWindow();
            std::printf("  part %d name=%s type=%s compression=%s dw=(%d,%d)-(%d,%d) disp=(%d,%d)-(%d,%d)", p,
                        h.hasName() ? h.name().c_str() : "-", h.hasType() ? h.type().c_str() : "-",
                        h.compression() < 10 ? comp[h.compression()] : "?", dw.min.x, dw.min.y, dw.max.x, dw.max.y,
                        disp.min.x, disp.min.y, disp.max.x, disp.max.y);
            if (h.hasTileDescription()) {
                const Imf::TileDescription &t = h.tileDescription();
                static const char *mode[] = {"one", "mipmap", "ripmap"};
                std::printf(" tiles=%ux%u levels=%s", t.xSize, t.ySize, t.mode < 3 ? mode[t.mode] : "?");
            }
            std::printf("\n   ");
            static const char *pt[] = {"u32", "f16", "f32"};
            for (auto c = h.channels().begin(); c != h.channels().end(); ++c)
                std::printf(" %s:%s%s", c.name(), pt[c.channel().type],
                            c.channel().xSampling != 1 || c.channel().ySampling != 1
                                ? ("/" + std::to_string(c.channel().xSampling) + "x" +
                                   std::to_string(c.channel().ySampling))
                                      .c_str()
                                : "");
            std::printf("\n");
        }
    }
    return 0;
}

static bool is_deep(const Imf::Header &h) {
    return h.hasType() && (h.type() == Imf::DEEPSCANLINE || h.type() == Imf::DEEPTILE);
}

// `find` of src/formats/exr.rs with an empty prefix.
static std::string find_channel(const Imf::ChannelList &list, const std::string &want) {
    if (list.findChannel(want)) return want;
    const std::string suffix = "." + want;
    for (auto c = list.begin(); c != list.end(); ++c) {
        std::string n = c.name();
        if (n.size() > suffix.size() && n.compare(n.size() - suffix.size(), suffix.size(), suffix) == 0) return n;
        if (n.size() == suffix.size() && n == suffix) return n;
    }
    return "";
}

static bool has_colour(const Imf::ChannelList &list) {
    for (const char *c : {"R", "G", "B", "Y"})
        if (!find_channel(list, c).empty()) return true;
    return false;
}

struct OutChannel {
    std::string name, source;
    std::vector<float> values;
};

static std::vector<float> read_float(Imf::MultiPartInputFile &file, int part, const std::string &name, int w,
                                     int h) {
    Imf::InputPart in(file, part);
    Imath::Box2i dw = in.header().dataWindow();
    std::vector<float> v(size_t(w) * h);
    Imf::FrameBuffer fb;
    char *base = (char *)(v.data() - dw.min.x - ptrdiff_t(dw.min.y) * w);
    fb.insert(name, Imf::Slice(Imf::FLOAT, base, sizeof(float), sizeof(float) * size_t(w)));
    in.setFrameBuffer(fb);
    in.readPixels(dw.min.y, dw.max.y);
    return v;
}

static int channels(int argc, char **argv) {
    std::string root = argv[2];
    std::printf("{\n \"oracle\": \"OpenEXR %s (MultiPartInputFile/InputPart as FLOAT; RgbaInputFile for subsampled "
                "luminance/chroma)\",\n \"files\": {",
                OPENEXR_VERSION_STRING);
    for (int f = 3; f < argc; ++f) {
        std::string path = root + "/" + argv[f];
        Imf::MultiPartInputFile file(path.c_str());
        int part = -1;
        for (int p = 0; p < file.parts() && part < 0; ++p)
            if (!is_deep(file.header(p)) && has_colour(file.header(p).channels())) part = p;
        if (part < 0) throw std::runtime_error(path + ": no part with a colour channel");
        const Imf::Header &header = file.header(part);
        Imath::Box2i dw = header.dataWindow();
        int w = dw.max.x - dw.min.x + 1, h = dw.max.y - dw.min.y + 1;
        const Imf::ChannelList &list = header.channels();
        std::string r = find_channel(list, "R"), g = find_channel(list, "G"), b = find_channel(list, "B"),
                    y = find_channel(list, "Y"), a = find_channel(list, "A"), ry = find_channel(list, "RY"),
                    by = find_channel(list, "BY");
        std::vector<OutChannel> out;
        std::string mode;
        if (!r.empty() || !g.empty() || !b.empty()) {
            mode = "rgb";
            for (auto &c : {std::make_pair("R", r), std::make_pair("G", g), std::make_pair("B", b)}) {
                if (c.second.empty())
                    out.push_back({c.first, "", std::vector<float>(size_t(w) * h, 0.0f)});
                else
                    out.push_back({c.first, c.second, read_float(file, part, c.second, w, h)});
            }
        } else {
            auto sub2 = [&](const std::string &n) {
                const Imf::Channel *c = list.findChannel(n);
                return c && c->xSampling == 2 && c->ySampling == 2;
            };
            if (sub2(ry) && sub2(by)) {
                mode = "yca";
                std::string prefix = y.substr(0, y.size() - 1);
                if (part != 0 || ry != prefix + "RY" || by != prefix + "BY")
                    throw std::runtime_error(path + ": luminance/chroma outside part 0 or across layers");
                if (!prefix.empty()) prefix.pop_back();
                Imf::RgbaInputFile in(path.c_str(), prefix);
                std::vector<Imf::Rgba> px(size_t(w) * h);
                in.setFrameBuffer(px.data() - dw.min.x - ptrdiff_t(dw.min.y) * w, 1, w);
                in.readPixels(dw.min.y, dw.max.y);
                OutChannel oc[3] = {{"R", y + "->R", {}}, {"G", y + "->G", {}}, {"B", y + "->B", {}}};
                for (const Imf::Rgba &p : px) {
                    oc[0].values.push_back(p.r);
                    oc[1].values.push_back(p.g);
                    oc[2].values.push_back(p.b);
                }
                for (auto &c : oc) out.push_back(std::move(c));
            } else if (ry.empty() && by.empty()) {
                mode = "y";
                out.push_back({"Y", y, read_float(file, part, y, w, h)});
                a.clear();
            } else {
                throw std::runtime_error(path + ": full-resolution chroma is not covered by this oracle");
            }
        }
        if (!a.empty()) out.push_back({"A", a, read_float(file, part, a, w, h)});

        std::printf("%s\n  \"%s\": {\n   \"part\": %d,\n   \"mode\": \"%s\",\n   \"size\": [%d, %d],\n   "
                    "\"data_window\": [%d, %d, %d, %d],\n   \"display_window\": [%d, %d, %d, %d],\n   \"channels\": [",
                    f > 3 ? "," : "", argv[f], part, mode.c_str(), w, h, dw.min.x, dw.min.y, dw.max.x, dw.max.y,
                    header.displayWindow().min.x, header.displayWindow().min.y, header.displayWindow().max.x,
                    header.displayWindow().max.y);
        for (size_t k = 0; k < out.size(); ++k) {
            const OutChannel &c = out[k];
            uint64_t hash = 1469598103934665603ull;
            double sum = 0;
            long count = 0;
            for (float v : c.values) {
                uint32_t bits;
                std::memcpy(&bits, &v, 4);
                for (int i = 0; i < 4; ++i) {
                    hash ^= (bits >> (8 * i)) & 0xff;
                    hash *= 1099511628211ull;
                }
                if (std::isfinite(v)) {
                    sum += v;
                    ++count;
                }
            }
            std::printf("%s\n    {\"name\": \"%s\", \"source\": \"%s\", \"fnv1a64_f32_bits\": \"%016" PRIx64
                        "\", \"mean\": %.17g, \"samples\": [",
                        k ? "," : "", c.name.c_str(), c.source.c_str(), hash, count ? sum / count : 0.0);
            for (int j = 0; j < 5; ++j)
                for (int i = 0; i < 5; ++i) {
                    int x = (int)std::lround(i * (w - 1) / 4.0), yy = (int)std::lround(j * (h - 1) / 4.0);
                    float v = c.values[size_t(yy) * w + x];
                    // JSON has no NaN/Infinity: those as strings.
                    if (std::isfinite(v))
                        std::printf("%s[%d, %d, %.9g]", i + j ? ", " : "", x, yy, v);
                    else
                        std::printf("%s[%d, %d, \"%s\"]", i + j ? ", " : "", x, yy,
                                    std::isnan(v) ? "NaN" : (v > 0 ? "inf" : "-inf"));
                }
            std::printf("]}");
        }
        std::printf("\n   ]\n  }");
    }
    std::printf("\n }\n}\n");
    return 0;
}

int main(int argc, char **argv) {
    if (argc >= 2 && std::string(argv[1]) == "--info") return info(argc, argv);
    if (argc >= 3 && std::string(argv[1]) == "--channels") return channels(argc, argv);
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
