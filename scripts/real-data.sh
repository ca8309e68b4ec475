#!/usr/bin/env bash
# Real captures of two other people's colour-stripe systems, converted into stripelight's
# pattern spec and calibration, scanned, and scored (coverage and fit to the known shape).
#
#   scripts/real-data.sh MIRRORS OUT
#
# MIRRORS holds the two public repositories as already fetched, either as git directories
# (MIRRORS/Zion1123+deBruijn-single-shot-structured-light/repo and
# MIRRORS/tingck+color-structured-light/repo, as the fetch tool leaves them) or checked out
# (MIRRORS/deBruijn-single-shot-structured-light/ and MIRRORS/color-structured-light/).
# OUT is a scratch folder (made if missing) for their files, the converted spec and
# calibration, the scans and the figures. The script downloads nothing and commits
# nothing; the repositories carry no licence, so none of their files may enter this one.
#
# 1. Zion1123/deBruijn-single-shot-structured-light: demo/Data/image/reconstruction/test.png,
#    a 1280x1024 frame of a sphere under 64 colour lobes (red, green, blue; de Bruijn
#    B(3,4), the first 64 symbols) 14 projector pixels apart, dark between lobes, centres
#    at u = 7.5 + 14 i (demo/CoreAlgorithm.cpp). Modelled as 127 flat stripes 7 pixels
#    wide, colour / black alternating, starting at u = 4 (a lobe's half-maximum width);
#    black background. Projector 912x1140 (inferred: fy = 2 fx and the principal point
#    of a DLP LightCrafter 4500's diamond array; 64 x 14 = 896 fits). Calibration typed
#    into demo/main.cpp: Hc = Kc [I|0], Hp = Kp [R|t], so X_p = R X_c + t, t in mm, no
#    distortion. No radius is stated; their own reconstruction fits 97.4 mm.
# 2. tingck/color-structured-light (Zhang, Curless, Seitz 2002): sample_data/wall.jpg and
#    hand.jpg, 3264x2448 JPEG; pattern2.bmp holds the 125 stripes of 8 colours (2 bmp
#    pixels each); triangulate_test.m puts them 3 projector pixels wide after a 27-pixel
#    margin; loadParams.m gives the projector as 427x480; the margins are white.
#    calibration.m is Bouguet-style text (camera left, projector right, X_p = R X_c + T,
#    T in mm), imported as it is.
#
# Figures on 2026-12-04, after subpixel_peak (coverage = object pixels with a point;
# fit = least squares; docs/third-party.md has the earlier ones):
#   zion default (gamma 2.2)           0 points: the black gaps are below the dark level
#   zion linear (gamma 1)              25.7 %, radius 95.4 mm, RMS 0.68 mm, 0.75 % > 2 mm
#   zion linear, direct                27.6 %, radius 97.0 mm, RMS 0.83 mm, 2.7 % > 2 mm
#   zion linear, measured mixing        0 points
#   zion linear, green-into-blue only  25.7 %, radius 95.4 mm, RMS 0.71 mm, 1.0 % > 2 mm
#   tingck wall                         9.4 %, plane RMS 15.0 mm
#   tingck hand                         0.98 %
# and on 2026-12-06, after both-sides-clipped channels read as unchanged: tingck wall
# 25.8 %, its stripe coordinates 96.6 % within a quarter of a stripe of a smooth field
# and 0.06 % a stripe or more off; hand 3.0 % (docs/third-party.md). With the colour mixing
# read from the frame itself (--crosstalk frame, 2026-12-06): tingck wall 39.0 % (97.7 %
# within a quarter of a stripe), the hand and Zion give no estimate and scan with none.
# On 2026-12-07 the tingck frames are decoded at half the scale (a projector pixel covers
# about 5 camera pixels; `scan --decode-scale`, default auto): wall 42.4 % (loggrad),
# 52.1 % (--crosstalk frame), hand 15.2 %; Zion is unchanged (its own scale). Later the
# same day, with stripes decoded through a misread boundary halfway between identified
# ones: wall 43.2 % (loggrad), 52.2 % (--crosstalk frame), hand 15.6 %, Zion 26.1 %.
#
# Needs: cargo, python3 (standard library only), git when MIRRORS holds git directories.
set -euo pipefail

if [ $# -ne 2 ]; then
    sed -n '2,12p' "$0" >&2
    exit 2
fi
MIRRORS=$(cd "$1" && pwd)
mkdir -p "$2"
OUT=$(cd "$2" && pwd)
ROOT=$(cd "$(dirname "$0")/.." && pwd)
case "$OUT/" in "$ROOT"/*) echo "OUT must be outside the repository" >&2; exit 2 ;; esac

# get OWNER NAME PATH DEST: one file of a fetched repository.
get() {
    local git_dir="$MIRRORS/$1+$2/repo" tree="$MIRRORS/$2"
    mkdir -p "$(dirname "$4")"
    if [ -d "$git_dir" ]; then
        git --git-dir="$git_dir" show "HEAD:$3" > "$4"
    elif [ -f "$tree/$3" ]; then
        cp "$tree/$3" "$4"
    else
        echo "neither $git_dir nor $tree/$3 exists" >&2
        exit 1
    fi
}

Z=$OUT/zion
T=$OUT/tingck
for f in demo/Data/image/reconstruction/test.png demo/main.cpp demo/CoreAlgorithm.cpp; do
    get Zion1123 deBruijn-single-shot-structured-light "$f" "$Z/src/$f"
done
for f in pattern2.bmp calibration.m loadParams.m triangulate_test.m sample_data/wall.jpg sample_data/hand.jpg; do
    get tingck color-structured-light "$f" "$T/src/$f"
done

(cd "$ROOT" && cargo build --release --bin stripelight --example fit_sphere)
B=$ROOT/target/release/stripelight
FIT=$ROOT/target/release/examples/fit_sphere

# Conversion: spec JSON, projector image PNG and (Zion) OpenCV YAML, read from their sources.
python3 - "$Z" "$T" <<'EOF'
import json, re, struct, sys, zlib

zdir, tdir = sys.argv[1], sys.argv[2]

def png(path, rows):
    """8-bit RGB PNG from rows of (r, g, b) tuples."""
    h, w = len(rows), len(rows[0])
    raw = b''.join(b'\0' + bytes(v for px in row for v in px) for row in rows)
    chunk = lambda t, d: struct.pack('>I', len(d)) + t + d + struct.pack('>I', zlib.crc32(t + d))
    with open(path, 'wb') as f:
        f.write(b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', struct.pack('>IIBBBBB', w, h, 8, 2, 0, 0, 0))
                + chunk(b'IDAT', zlib.compress(raw, 9)) + chunk(b'IEND', b''))

def transition(a, b):
    return tuple(0 if x == y else (1 if y > x else -1) for x, y in zip(a, b))

def least_window(palette, seq):
    for w in range(2, len(seq) + 1):
        keys = [tuple(transition(palette[seq[j]], palette[seq[j + 1]]) for j in range(i, i + w - 1))
                for i in range(len(seq) - w + 1)]
        if len(set(keys)) == len(keys):
            return w

def write_spec(path, width, height, palette, seq, stripe_width, first_u, background=(0, 0, 0)):
    """One family of vertical stripes; stripe 0 starts at projector column first_u
    (pixel edges at half integers), the spec's origin s = u - (W - 1) / 2."""
    spec = {'format': 'stripelight-pattern', 'version': 1, 'width': width, 'height': height,
            'encoding_gamma': 2.2, 'palette': palette, 'sequence': seq,
            'window': least_window(palette, seq),
            'families': [{'angle_deg': 0.0, 'stripe_width': stripe_width,
                          'origin': first_u - (width - 1) / 2, 'count': len(seq)}]}
    if any(background):
        spec['background'] = list(background)
    with open(path, 'w') as f:
        json.dump(spec, f, indent=1)
    row = []
    for u in range(width):
        j = int((u - first_u) // stripe_width)
        c = palette[seq[j]] if 0 <= j < len(seq) else background
        row.append(tuple(round(255 * v) for v in c))
    png(path.replace('spec.json', 'pattern.png'), [row] * height)
    return spec

# --- Zion1123: de Bruijn B(k, n) as CoreAlgorithm.cpp builds it, lobes period 14.
core = open(f'{zdir}/src/demo/CoreAlgorithm.cpp', encoding='latin-1').read()
k, n = map(int, re.search(r'DeBruijn\((\d+),\s*(\d+)\)\s*;', core).groups())
windows = int(re.search(r'for \(auto i = 0; i < (\d+); i\+\+\)\s*\{\s*//[^\n]*\n\s*int index', core).group(1))
centre0, period = map(float, re.search(r'map\[index\] = ([\d.]+) \+ ([\d.]+) \* i', core).groups())
a, seq = [0] * (k * n), []
def db(t, p):
    if t > n:
        if n % p == 0:
            seq.extend(a[1:p + 1])
    else:
        a[t] = a[t - p]; db(t + 1, p)
        for j in range(a[t - p] + 1, k):
            a[t] = j; db(t + 1, t)
db(1, 1)
lobes = (seq + seq[:n - 1])[:windows + n - 1]       # labels 0 red, 1 green, 2 blue
stripes = [x for i, c in enumerate(lobes) for x in ([c, 3] if i < len(lobes) - 1 else [c])]
half = period / 2
spec = write_spec(f'{zdir}/spec.json', 912, 1140, [[1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, 0]],
                  stripes, half, centre0 - half / 2)
print(f'zion: B({k},{n}), {len(lobes)} lobes, {len(stripes)} stripes of {half} px from u = {centre0 - half / 2}, window {spec["window"]}')

main = open(f'{zdir}/src/demo/main.cpp', encoding='utf-8', errors='replace').read()
num = r'-?\d+\.?\d*(?:e[+-]?\d+)?'
def matrix(name):
    body = re.search(r'double ' + name + r'\[[^=]*=\s*\{(.*?)\};', main, re.S).group(1)
    return [float(x) for x in re.findall(num, body)]
R, t, Kc, Kp = matrix('m0'), matrix('m1'), matrix('m2'), matrix('m3')
assert (len(R), len(t), len(Kc), len(Kp)) == (9, 3, 9, 9)
yml = ['%YAML:1.0', '---', 'imageSize: [ 1280, 1024 ]']
for key, rows, cols, vals in [('cameraMatrix1', 3, 3, Kc), ('distCoeffs1', 1, 5, [0] * 5),
                              ('cameraMatrix2', 3, 3, Kp), ('distCoeffs2', 1, 5, [0] * 5),
                              ('R', 3, 3, R), ('T', 3, 1, t)]:
    yml += [f'{key}: !!opencv-matrix', f'   rows: {rows}', f'   cols: {cols}', '   dt: d',
            '   data: [ ' + ', '.join(repr(float(v)) for v in vals) + ' ]']
open(f'{zdir}/calib_opencv.yml', 'w').write('\n'.join(yml) + '\n')

# --- tingck: the stripe colours from pattern2.bmp's first row, every other pixel.
bmp = open(f'{tdir}/src/pattern2.bmp', 'rb').read()
off = struct.unpack_from('<I', bmp, 10)[0]
w, h = struct.unpack_from('<ii', bmp, 18)
bpp = struct.unpack_from('<H', bmp, 28)[0]
assert bpp == 24, bpp
stride = (w * 3 + 3) // 4 * 4
top = off + (abs(h) - 1) * stride if h > 0 else off      # bottom-up unless h < 0
cols = [tuple(bmp[top + 3 * x + 2 - c] > 127 for c in range(3)) for x in range(0, w, 2)]
palette = [[(i >> 2) & 1, (i >> 1) & 1, i & 1] for i in range(8)]   # index = 4 R + 2 G + B
seq = [4 * r + 2 * g + b for r, g, b in cols]
tri = open(f'{tdir}/src/triangulate_test.m').read()
pad = int(re.search(r'pattern_padding_len = (\d+)', tri).group(1))
width_px = int(re.search(r'pattern_stripe_width = (\d+)', tri).group(1))
lp = open(f'{tdir}/src/loadParams.m').read()
pw, ph = (int(re.search(name + r' = (\d+)', lp).group(1)) for name in ('pro_width', 'pro_height'))
cw, ch = (int(re.search(name + r' = (\d+)', lp).group(1)) for name in ('cam_width', 'cam_height'))
spec = write_spec(f'{tdir}/spec.json', pw, ph, palette, seq, float(width_px), pad - 0.5, (1, 1, 1))
open(f'{tdir}/sizes', 'w').write(f'{cw}x{ch} {pw}x{ph} {width_px}\n')
print(f'tingck: {len(seq)} stripes of {width_px} px from u = {pad - 0.5} on {pw}x{ph}, window {spec["window"]}, white margins')
EOF

"$B" calib import --from "$Z/calib_opencv.yml" --out "$Z/calib.json" --projector-size 912x1140
read -r CAM PROJ STRIPE < "$T/sizes"
"$B" calib import --from "$T/src/calibration.m" --out "$T/calib.json" --camera-size "$CAM" --projector-size "$PROJ"

# The same patterns read back by `pattern import` from the projector images written above,
# for comparison (Zion's image samples the stripes at pixel centres, half a pixel from
# the spec's u = 4, and its 4 black columns on the left become a first, cut stripe).
"$B" pattern import --image "$Z/pattern.png" --out "$Z/spec-imported.json"
"$B" pattern import --image "$T/pattern.png" --out "$T/spec-imported.json"

# Zion: each configuration is NAME GAMMA CROSSTALK FILTER. The camera is linear (in the
# lobes the ratios between channels stay the same from code 20 to 250), so gamma 1; at
# the default 2.2 the dark gaps between lobes (codes 9-15) fall under the decoder's dark
# level. The measured colour mixing is the frame's own: camera RGB at the red, green and
# blue lobe peaks less the black level, rows normalised as `stripelight crosstalk` prints
# them. "green-into-blue" corrects only the largest leak (a diagnostic, not a measurement).
ZIMG=$Z/src/demo/Data/image/reconstruction/test.png
while read -r name gamma xt filter; do
    args=(--camera-gamma "$gamma" --filter "$filter")
    [ "$xt" = none ] || args+=(--crosstalk "$xt")
    mkdir -p "$Z/scan-$name"
    "$B" scan --spec "$Z/spec.json" --calib "$Z/calib.json" --image "$ZIMG" "${args[@]}" \
        --ply "$Z/scan-$name/cloud.ply" --correspondence "$Z/scan-$name/corr.pfm" \
        --debug "$Z/scan-$name/stages" 2> "$Z/scan-$name/log.txt"
    echo "== zion $name (gamma $gamma, crosstalk $xt, $filter): $(grep -v '^colour mixing' "$Z/scan-$name/log.txt" | head -1)"
    grep '^colour mixing' "$Z/scan-$name/log.txt" || true
    # The sphere: inside the circle fitted to its lit outline (centre 655.3, 449.2,
    # radius 234.4 px, less 4 px), pixels whose brightest channel within 12 px left or
    # right exceeds 30 (so the dark gaps between lobes count as lit).
    "$FIT" "$Z/scan-$name/cloud.ply" --image "$ZIMG" --circle 655.3,449.2,230 --threshold 30 \
        --spread 12 --write-mask "$Z/mask.png" --expect-radius 97.4 || true
done <<'CONFIGS'
default 2.2 none loggrad
linear 1.0 none loggrad
linear-direct 1.0 none direct
linear-measured 1.0 0.770,0.206,0.024,0.099,0.828,0.073,0.056,0.371,0.573 loggrad
linear-green-into-blue 1.0 1,0,0,0,1,0,0,0.4,0.6 loggrad
linear-frame 1.0 frame loggrad
CONFIGS

# tingck: the wall is a plane. Object = the striped part of the projection (corners found
# on wall.jpg where the white margins end, inset 5 px), brightest channel within 30 px
# above 60. On the wall, the stripe coordinates are also scored against a smooth field
# (a wrong identity is a whole stripe off it), which the rig's calibration does not
# affect.
POLY=301,300,2729,300,2575,1708,501,1708
# The third run of each frame reads the colour mixing from the frame itself (`--crosstalk
# frame`, loggrad); its log's first lines are the estimates.
for img in wall hand; do
    for filter in loggrad direct frame; do
        tag=$img-$filter
        args=(--filter "$filter")
        [ "$filter" = frame ] && args=(--filter loggrad --crosstalk frame)
        mkdir -p "$T/scan-$tag"
        "$B" scan --spec "$T/spec.json" --calib "$T/calib.json" --image "$T/src/sample_data/$img.jpg" \
            "${args[@]}" --ply "$T/scan-$tag/cloud.ply" --correspondence "$T/scan-$tag/corr.pfm" \
            --debug "$T/scan-$tag/stages" 2> "$T/scan-$tag/log.txt"
        echo "== tingck $tag: $(grep -v '^colour mixing' "$T/scan-$tag/log.txt" | head -1)"
        grep '^colour mixing' "$T/scan-$tag/log.txt" || true
        # The hand has no known shape: its plane fit means nothing, read only its coverage.
        stripes=()
        [ "$img" = wall ] && stripes=(--correspondence "$T/scan-$tag/corr.pfm" --stripe-width "$STRIPE")
        "$FIT" "$T/scan-$tag/cloud.ply" --image "$T/src/sample_data/$img.jpg" --polygon "$POLY" \
            --threshold 60 --spread 30 --shape plane --write-mask "$T/mask-$img.png" "${stripes[@]}" || true
    done
done

# A diagnostic, not a measurement: the wall with a colour mixing set by hand from its own
# stripes on row 1100 (linear light, less the black stripe's): the blue stripe shows
# about 0.05 of its blue in red and 0.11 in green, the red stripe about 0.2 of its red
# in blue; rows scaled to sum to 1. No frames of the primaries come with the captures,
# so `stripelight crosstalk` cannot measure it.
tag=wall-mixing-by-hand
mkdir -p "$T/scan-$tag"
"$B" scan --spec "$T/spec.json" --calib "$T/calib.json" --image "$T/src/sample_data/wall.jpg" \
    --crosstalk 0.95,0,0.05,0,0.9,0.1,0.17,0,0.83 --ply "$T/scan-$tag/cloud.ply" \
    --correspondence "$T/scan-$tag/corr.pfm" 2> "$T/scan-$tag/log.txt"
echo "== tingck $tag: $(head -1 "$T/scan-$tag/log.txt")"
"$FIT" "$T/scan-$tag/cloud.ply" --image "$T/src/sample_data/wall.jpg" --polygon "$POLY" --threshold 60 \
    --spread 30 --shape plane --correspondence "$T/scan-$tag/corr.pfm" --stripe-width "$STRIPE" || true
