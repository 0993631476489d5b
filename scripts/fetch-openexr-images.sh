#!/usr/bin/env bash
# Fetches the OpenEXR project's test images that tests/exr_fetched_conformance.rs compares
# against tests/data/openexr/expected-fetched.json (values OpenEXR 3.1.5 itself computed, by
# scripts/openexr-cpp-oracle.cpp --channels). The files ship in tests/data/openexr-images (the
# test's default folder; CI requires them with HDRFLOW_REQUIRE_OPENEXR_IMAGES=1): this script
# re-creates or checks that folder.
#
#     scripts/fetch-openexr-images.sh [DIR]                      # from GitHub (curl)
#     scripts/fetch-openexr-images.sh --from-git-dir GIT [DIR]   # from a local clone (no network)
#
# DIR defaults to tests/data/openexr-images (the test's default; elsewhere, set
# HDRFLOW_OPENEXR_IMAGES=DIR for the test). Files come from
# https://github.com/AcademySoftwareFoundation/openexr-images at the pinned commit below
# (BSD-3-Clause, see tests/data/openexr/LICENSE), 44 files, 32.4 MB. A file already present with
# the right sha256 is kept; every file is checked against the sha256 listed here, and a wrong one
# is deleted and the script fails. `--from-git-dir` reads `git show COMMIT:PATH` from a clone
# (or bare repository) holding that commit, for machines that cannot reach GitHub.
set -euo pipefail

COMMIT=e38ffb0790f62f05a6f083a6fa4cac150b3b7452
BASE="https://raw.githubusercontent.com/AcademySoftwareFoundation/openexr-images/$COMMIT"

GIT_DIR_SRC=""
if [ "${1:-}" = "--from-git-dir" ]; then
    GIT_DIR_SRC="${2:?--from-git-dir needs a directory}"
    shift 2
fi
DIR="${1:-tests/data/openexr-images}"

# sha256, size in bytes, path in the repository.
FILES="
5a1b2ca1a716c736bfcfdabb8e5cc6b533dbd9f937da59bc5adc66913de9442f 1304619 LuminanceChroma/CrissyField.exr
d1016a9177e723122f982fe79077dd71d42bf2b4da565d35f4c728f8a5688236 758083 LuminanceChroma/Flowers.exr
4eaf0f7afe3a2e73d10c556ff1aab180f8b0e4b3e9a72971aed6518661d5a833 1422492 LuminanceChroma/MtTamNorth.exr
e01b852ddeb8dcb0b7924ce016befcd88e4539b26dbd46a5cdd66ff6201e560c 2038226 LuminanceChroma/StarField.exr
c19060f8252ec7cce66979c04c883766d70343ca1916ccc538d02eea982cfc66 399046 LuminanceChroma/Garden.exr
8790ad440e8708a05044d646082e876327ceba759052dffa7adf8eb7c170bca0 3693609 Tiles/GoldenGate.exr
1ac7ae21c22fe1b006f18e3b6b53d52330fb7314ba4b1e0c68016967182d0fa9 1163637 ScanLines/Cannon.exr
892d9eb1d2b22a3c7c57d22fa60c33aaa4a49ba3ead5304ec594b274aa39e4e1 914825 ScanLines/Carrots.exr
2734d15e1ce157f73feaae5033b148bdabc98acb3084e9d892c6b01f23c24854 2424523 ScanLines/Desk.exr
ba836f7d37ea268ef9e96d7f0e28d035f4f197be12356133676282c578ada643 53298 MultiResolution/ColorCodedLevels.exr
3b9b88f82e80d8ca3d5e55bfc4117a733c0a2d7abe9de7ed372ea05caa9bca2e 2303675 MultiResolution/Bonita.exr
8f5a8d17703a4c61f0a25f436eafb11f0042e836f269cdb63c6d63804f1992f9 228020 MultiResolution/PeriodicPattern.exr
21379fd0ee4aa2f45f1dbda58bc74addade4ccb6389e17630cdaab0b556b053b 1800876 MultiResolution/KernerEnvCube.exr
34b1ce44803f9486db8eaea5e1b5f828698797ee7a437ecf62851d9138e10279 464456 MultiResolution/WavyLinesLatLong.exr
ac19827f128ef1c7b4561a45d7e253f7cb080009e696832b51d903eee76566ae 251021 MultiResolution/WavyLinesSphere.exr
966aa7bbdaec18262c96b0332365da723f537087285b99b1589cb573c5e05269 4156415 MultiView/Adjuster.exr
8fab93675582862213d043aaa281438d399ab8d19e5a49fa7a0e50d49903c419 1447915 MultiView/Fog.exr
47d75e07b69ae358cbb2cbbef084c11b3e83d401996b5a44817b8ee03747ae51 1401773 v2/LowResLeftView/composited.exr
eede573a0b59b79f21de15ee9d3b7649d58d8f2a8e7787ea34f192db3b3c84a4 70769 TestImages/AllHalfValues.exr
1d32ea056eda34c6dad50a770ca4c262875056fe47e429f90a3f1d2736570bb6 151163 TestImages/BrightRingsNanInf.exr
7b038f9f43e0a69b779f1ffb519a50b910d13717d7b0aab8adb2328682e6673f 70935 TestImages/WideFloatRange.exr
7140e9262ff518215e610fc5d4584ae470e50f8b0e7f21eb403f5b1684a33101 172826 TestImages/WideColorGamut.exr
bb2819850542afae5e2208ba39724c23fe1a07b80b96f4fd093b3c9a3ca8ac2f 23272 TestImages/GammaChart.exr
7858e712af500e737ebaedbf40730646529e6093371ddb939becc58700b8fc6a 18296 TestImages/GrayRampsHorizontal.exr
6037f9e122431eeaa084843c56255bf85d044a859e98df856cb69b24b2d49b4b 133681 TestImages/RgbRampsDiagonal.exr
a4c11b79d256fb6945087dc9b244e814264a128aeb2fefacc303c32d08e426a1 4657 TestImages/stripes.exr
29719942ed3c095a8f8f111fc139fc4c28f446007f5bfce00177cae585b1a87a 2347698 Beachball/singlepart.0001.exr
0cd032069fbaa14a2766861fef9893ea66a6494ff64650725d3b26a500df774b 2894260 Beachball/multipart.0001.exr
adc51278b0ceaa3475f58a9abc5cb5dec79c4590b9db773009e6ffcfdfd81643 20829 DisplayWindow/t01.exr
0ef9bf41902af9ae8cc981068cd5948cb9629bc65c4943ae5b6daec4fcdcd0e1 20829 DisplayWindow/t02.exr
c9708d458aaa9849325604200be4bf7958ac77594c928da234da4826b0df8c62 20829 DisplayWindow/t03.exr
ca9cafa344aeaa211672df498abcdf95aa429d3b2bb380b35fea39a9e9fa73da 20829 DisplayWindow/t04.exr
ab242bfa21826af2cba883c0257866cfe2300e5c97b7e6687d0e8dc3dc4851dc 20829 DisplayWindow/t05.exr
920191add20f19592ddf925127162d40bf823d6f73e691f39a893aaefe78f7fa 20829 DisplayWindow/t06.exr
11310a48a95814b197ae3306da280930d6f6b47b650a0ab48375f1201b6a914e 20829 DisplayWindow/t07.exr
fd92b685cdcd946aceb39bc033bf89abf53973b767a910907c5aabbe41abbb61 20829 DisplayWindow/t08.exr
4b57630afbe015efd01998857f033dd26236be60a042827faba7afa2c853390c 20829 DisplayWindow/t09.exr
21ed7000c20eb3249247c5eda682da57c41ef3631a50510e837d8c9f8322d16a 20829 DisplayWindow/t10.exr
a0e2e4a6c3423c6f9e07e0113927792a6e8c5e14873fcc4f2252cdad3e3d8852 20829 DisplayWindow/t11.exr
48af99e71d55beee90cdbe3d5b0edb36de34d007dabb032a48f78ab5f2ab2ed9 20829 DisplayWindow/t12.exr
e779baaed0563955213f99daf07f903727f9100c3b6ea342302d0f0a32607d2a 20829 DisplayWindow/t13.exr
35c8089aab3a1d6a6feba00b51d8d4ce90ad67fc1eff68750167c00c5bc89597 20829 DisplayWindow/t14.exr
e2709c5751fe7be902c0fa6c7d4039f98bc1e2ad159246cf0ef2fac9112ffee1 20829 DisplayWindow/t15.exr
60e0dc9eed128514847c0bf3a482e9ac7294feb6a74bc1a69c3faad8514cd526 20829 DisplayWindow/t16.exr
"

sha256() {
    if command -v sha256sum >/dev/null; then sha256sum "$1" | cut -d' ' -f1; else shasum -a 256 "$1" | cut -d' ' -f1; fi
}

fetched=0 kept=0 total=0
while read -r sum size path; do
    [ -n "$path" ] || continue
    total=$((total + 1))
    out="$DIR/$path"
    if [ -f "$out" ] && [ "$(wc -c <"$out" | tr -d ' ')" = "$size" ] && [ "$(sha256 "$out")" = "$sum" ]; then
        kept=$((kept + 1))
        continue
    fi
    mkdir -p "$(dirname "$out")"
    if [ -n "$GIT_DIR_SRC" ]; then
        git -C "$GIT_DIR_SRC" show "$COMMIT:$path" >"$out.part"
    else
        curl --fail --location --silent --show-error --retry 5 --retry-delay 2 --connect-timeout 20 \
            -o "$out.part" "$BASE/$path"
    fi
    got="$(sha256 "$out.part")"
    if [ "$got" != "$sum" ]; then
        rm -f "$out.part"
        echo "error: $path: sha256 $got, expected $sum" >&2
        exit 1
    fi
    mv "$out.part" "$out"
    fetched=$((fetched + 1))
    echo "fetched $path ($size bytes)"
done <<<"$FILES"
echo "$total files in $DIR: $fetched fetched, $kept already present"
