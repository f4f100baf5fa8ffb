#!/usr/bin/env python3
"""The real-terrain planning corpus of issue 18: plans and flies a set of cases on real and
rough synthetic DEMs and prints a Markdown table (case, optimizer outcome, iterations, planning
time, objective against the initial paths', minimum terrain clearance reported and re-checked
on the source DEM).

    scripts/terrain_corpus.py --ridgeline build/ridgeline --dem ../shared/dem/zion_srtm3.tif \
        --out out/corpus

Cases: windows of an SRTM tile in degrees (a geodetic origin each), the same tile reprojected
to UTM at 30 m and 90 m cells (gdalwarp, bilinear), and ridged fractal noise at 10 m and 30 m
cells; 3-8 UAVs start in the lowest ground of the west part of the area, targets sit 45 m above
the highest ground of the east part (ridges, across the valleys between). The re-check carries
every row of trajectories.csv to the DEM's own coordinates (gdaltransform, i.e. PROJ) and
interpolates the source pixels bilinearly, independently of Ridgeline's terrain code.
Needs gdal-bin (gdalwarp, gdal_translate, gdaltransform, gdalinfo).
"""
import argparse
import json
import math
import os
import random
import shutil
import subprocess
import sys

H_SAFE = 30.0


def fail(message):
    print(f'error: {message}', file=sys.stderr)
    sys.exit(2)


def sh(*args, **kw):
    return subprocess.run(args, check=True, capture_output=True, text=True, **kw)


class Grid:
    """An ESRI ASCII grid read into memory (row 0 south), bilinear on cell centres."""

    def __init__(self, path):
        with open(path) as f:
            tokens = f.read().split()
        hdr, k = {}, 0
        while tokens[k][0].isalpha():  # the header: keyword value pairs
            hdr[tokens[k].lower()] = float(tokens[k + 1])
            k += 2
        vals = [float(x) for x in tokens[k:]]
        self.nc, self.nr = int(hdr['ncols']), int(hdr['nrows'])
        self.cx = hdr.get('cellsize', hdr.get('dx'))
        self.cy = hdr.get('cellsize', hdr.get('dy'))
        self.x0 = hdr['xllcorner'] + self.cx / 2
        self.y0 = hdr['yllcorner'] + self.cy / 2
        self.v = vals

    def at(self, r, c):
        return self.v[(self.nr - 1 - r) * self.nc + c]

    def height(self, x, y):
        u, w = (x - self.x0) / self.cx, (y - self.y0) / self.cy
        c = min(max(int(math.floor(u)), 0), self.nc - 2)
        r = min(max(int(math.floor(w)), 0), self.nr - 2)
        a, b = u - c, w - r
        return ((1 - a) * (1 - b) * self.at(r, c) + a * (1 - b) * self.at(r, c + 1) +
                (1 - a) * b * self.at(r + 1, c) + a * b * self.at(r + 1, c + 1))


def ridged_fractal(path, n, cell, seed):
    """Ridged multifractal value noise, n x n cells, written as an .asc without CRS."""
    rnd = random.Random(seed)
    octaves = []
    for o in range(6):
        size = 4 * 2 ** o + 1
        octaves.append([[rnd.uniform(-1, 1) for _ in range(size)] for _ in range(size)])

    def noise(grid, x, y):
        s = len(grid) - 1
        gx, gy = x * s, y * s
        i, j = min(int(gx), s - 1), min(int(gy), s - 1)
        a, b = gx - i, gy - j
        a, b = a * a * (3 - 2 * a), b * b * (3 - 2 * b)
        return ((1 - a) * (1 - b) * grid[j][i] + a * (1 - b) * grid[j][i + 1] +
                (1 - a) * b * grid[j + 1][i] + a * b * grid[j + 1][i + 1])

    with open(path, 'w') as f:
        f.write(f'ncols {n}\nnrows {n}\nxllcorner 0\nyllcorner 0\ncellsize {cell}\n')
        for line in range(n):
            y = (n - 1 - line) / (n - 1)
            row = []
            for c in range(n):
                x = c / (n - 1)
                h, amp, weight = 0.0, 1.0, 1.0
                for grid in octaves:
                    r = (1.0 - abs(noise(grid, x, y))) ** 2 * weight
                    weight = min(1.0, r * 2)
                    h += r * amp
                    amp *= 0.5
                row.append(f'{600 + 260 * h:.2f}')
            f.write(' '.join(row) + '\n')


def scenario_text(name, area, terrain, origin, starts, targets):
    lines = [f'name: {name}', 'seed: 11']
    if origin:
        lines.append(f'origin: {{lat_deg: {origin[0]}, lon_deg: {origin[1]}, alt_amsl_m: 1500}}')
    lines += [
        'altitude: {min_m: 10, max_m: 5000}',
        f'safety: {{terrain_clearance_m: {H_SAFE}}}',
        f'area: {{x_min_m: {area[0]}, x_max_m: {area[1]}, y_min_m: {area[2]}, y_max_m: {area[3]}}}',
        f'terrain: {{dem: {{path: {terrain}, model: raster}}}}', 'uavs:']
    for k, (x, y, z) in enumerate(starts):
        lines.append(f'  - {{name: u{k + 1}, start: {{position_m: [{x:.1f}, {y:.1f}, {z:.1f}], '
                     'heading_deg: 0}}')
    lines.append('targets:')
    for k, (x, y, z) in enumerate(targets):
        lines.append(f'  - {{name: t{k + 1}, position_m: [{x:.1f}, {y:.1f}, {z:.1f}]}}')
    lines += ['threats: []', 'simulation: {duration_s: 1800}']
    return '\n'.join(lines) + '\n'


def pick_points(local, area, n_uavs, n_targets):
    """Starts: the lowest ground of the west quarter; targets: the highest of the east half."""
    cells = []
    for r in range(local.nr):
        for c in range(local.nc):
            x, y = local.x0 + c * local.cx, local.y0 + r * local.cy
            if area[0] + 150 < x < area[1] - 150 and area[2] + 150 < y < area[3] - 150:
                cells.append((local.at(r, c), x, y))
    width = area[1] - area[0]
    west = sorted(p for p in cells if p[1] < area[0] + 0.3 * width)
    east = sorted((p for p in cells if p[1] > area[0] + 0.55 * width), reverse=True)
    base = west[0]
    starts = []
    for k in range(n_uavs):  # a column 60 m apart around the lowest point, 70 m above ground
        x, y = base[1], base[2] + 60.0 * (k - (n_uavs - 1) / 2)
        y = min(max(y, area[2] + 50), area[3] - 50)
        starts.append((x, y, local.height(x, y) + 70.0))
    targets = []
    for h, x, y in east:
        if all(math.hypot(x - tx, y - ty) > 500.0 for tx, ty, _ in targets):
            targets.append((x, y, h + 45.0))
        if len(targets) == n_targets:
            break
    return starts, targets


def dem_label(dem_file, origin):
    if origin:
        return 'SRTM3, EPSG:4326'
    with open(dem_file.replace('.tif', '.asc')) as f:  # the header's cell size only
        header = dict(line.split()[:2] for line, _ in zip(f, range(6)))
    cell = int(float(header.get('cellsize', header.get('dx'))))
    return f'SRTM3 to UTM 12N, {cell} m' if dem_file.endswith('.tif') else f'ridged fractal, {cell} m'


def utm_corner(res):
    """West and south edges of utm{res}.tif, and its east and north edges."""
    info = json.loads(sh('gdalinfo', '-json', f'utm{res}.tif').stdout)
    gt = info['geoTransform']
    cols, rows = info['size']
    return gt[0], gt[3] + rows * gt[5], gt[0] + cols * gt[1], gt[3]


def fixed_cases(dem):
    """The ten cases of the README table: (name, dem file, origin or None, area, uavs, targets)."""
    ridged_fractal('ridged10.asc', 400, 10.0, 5)
    ridged_fractal('ridged30.asc', 200, 30.0, 8)
    cases = [
        ('srtm-deg-a', dem, (37.30, -113.00), (-2200, 2200, -2200, 2200), 3, 4),
        ('srtm-deg-b', dem, (37.22, -113.10), (-2500, 2500, -2000, 2000), 4, 4),
        ('srtm-deg-c', dem, (37.40, -112.95), (-2000, 2000, -2000, 2000), 5, 5),
        ('srtm-deg-d', dem, (37.25, -112.93), (-2500, 2500, -2500, 2500), 8, 6),
    ]
    for res in (30, 90):
        w, s, _, _ = utm_corner(res)
        # Windows around two UTM points, in the raster's corner frame (no origin).
        for tag, (e, nn) in (('a', (321000, 4131000)), ('b', (330000, 4121000))):
            cx, cy = e - w, nn - s
            cases.append((f'srtm-utm{res}-{tag}', os.path.abspath(f'utm{res}.tif'), None,
                          (cx - 2000, cx + 2000, cy - 2000, cy + 2000), 4 if tag == 'a' else 6, 4))
    cases.append(('ridged-10m', os.path.abspath('ridged10.asc'), None, (200, 3800, 200, 3800), 4, 4))
    cases.append(('ridged-30m', os.path.abspath('ridged30.asc'), None, (300, 5700, 300, 5700), 6, 5))
    return cases


def drawn_cases(dem, seed):
    """Ten cases drawn from `seed`, the mix of fixed_cases: four SRTM windows in degrees, two
    UTM 30 m and two UTM 90 m windows, two ridged fractal terrains (10 m and 30 m cells); areas
    of 3.6-5 km, 3-8 UAVs, 3-6 targets."""
    rnd = random.Random(seed)
    info = json.loads(sh('gdalinfo', '-json', dem).stdout)
    lon0, lat1 = info['geoTransform'][0], info['geoTransform'][3]
    lon1 = lon0 + info['size'][0] * info['geoTransform'][1]
    lat0 = lat1 + info['size'][1] * info['geoTransform'][5]
    cases = []
    for k in range(4):
        half_x, half_y = rnd.uniform(1800, 2500), rnd.uniform(1800, 2500)
        margin_lat, margin_lon = 0.03, 0.035  # > 2.5 km + the DEM cut's 500 m
        origin = (round(rnd.uniform(lat0 + margin_lat, lat1 - margin_lat), 4),
                  round(rnd.uniform(lon0 + margin_lon, lon1 - margin_lon), 4))
        cases.append((f's{seed}-deg-{k}', dem, origin, (-half_x, half_x, -half_y, half_y),
                      rnd.randint(3, 8), rnd.randint(3, 6)))
    for res in (30, 90):
        w, s, e, n = utm_corner(res)
        for k in range(2):
            half = rnd.uniform(1800, 2500)
            cx = rnd.uniform(half + 2000, e - w - half - 2000)  # off the warp's void wedges
            cy = rnd.uniform(half + 2000, n - s - half - 2000)
            cases.append((f's{seed}-utm{res}-{k}', os.path.abspath(f'utm{res}.tif'), None,
                          (cx - half, cx + half, cy - half, cy + half),
                          rnd.randint(3, 8), rnd.randint(3, 6)))
    for cell, size in ((10.0, 400), (30.0, 200)):
        name = f'ridged{seed}-{int(cell)}.asc'
        ridged_fractal(name, size, cell, 1000 + seed * 7 + int(cell))
        edge = 0.05 * cell * size
        cases.append((f's{seed}-ridged-{int(cell)}m', os.path.abspath(name), None,
                      (edge, cell * size - edge, edge, cell * size - edge),
                      rnd.randint(3, 8), rnd.randint(3, 6)))
    return cases


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--ridgeline', default='build/ridgeline')
    ap.add_argument('--dem', default=os.path.join(os.path.dirname(__file__),
                                                  '../../shared/dem/zion_srtm3.tif'))
    ap.add_argument('--out', default='out/corpus')
    ap.add_argument('--seed', type=int, default=None,
                    help='instead of the ten fixed cases, ten cases drawn from this seed: other '
                         'windows, UTM points, fractal terrains, team sizes and target counts')
    ap.add_argument('--plan-only', action='store_true',
                    help='plan each case (`ridgeline plan`) without flying it: no clearance '
                         're-check')
    a = ap.parse_args()
    rl = os.path.abspath(a.ridgeline)
    dem = os.path.abspath(a.dem)
    out = os.path.abspath(a.out)
    # Checked before anything is written.
    if not os.path.isfile(dem):
        fail(f'--dem: {a.dem}: no such file')
    if not os.access(rl, os.X_OK):
        fail(f'--ridgeline: {a.ridgeline}: not an executable (build it first)')
    for tool in ('gdalwarp', 'gdal_translate', 'gdaltransform', 'gdalinfo'):
        if shutil.which(tool) is None:
            fail(f'{tool} not found (Debian package gdal-bin)')
    probe = subprocess.run(['gdalinfo', dem], capture_output=True, text=True)
    if probe.returncode != 0:
        fail(f'--dem: {a.dem}: GDAL cannot read it: {probe.stderr.strip()}')
    os.makedirs(out, exist_ok=True)
    os.chdir(out)

    sh('gdal_translate', '-q', '-of', 'AAIGrid', dem, 'src_deg.asc')
    src_deg = Grid('src_deg.asc')
    for res in (30, 90):
        sh('gdalwarp', '-q', '-overwrite', '-t_srs', 'EPSG:32612', '-tr', str(res), str(res),
           '-r', 'bilinear', dem, f'utm{res}.tif')
        sh('gdal_translate', '-q', '-of', 'AAIGrid', f'utm{res}.tif', f'utm{res}.asc')
    cases = fixed_cases(dem) if a.seed is None else drawn_cases(dem, a.seed)

    print('| case | DEM | UAVs x targets | path source | Ipopt iterations | plan time s '
          '| objective / initial | min clearance reported / source re-check m |')
    print('|---|---|---|---|---|---|---|---|')
    optimized = 0
    for name, dem_file, origin, area, nu, nt in cases:
        # Heights in the local frame: the terrain sampled by `make-dem` over the area.
        draft = scenario_text(name, area, dem_file, origin,
                              [(area[0] + 100, area[2] + 100, 4900)],
                              [(area[1] - 100, area[3] - 100, 4900)])
        with open(f'{name}.draft.yaml', 'w') as f:
            f.write(draft)
        sh(rl, 'make-dem', '--scenario', f'{name}.draft.yaml', '--cell', '20',
           '--out', f'{name}.local.asc')
        local = Grid(f'{name}.local.asc')
        starts, targets = pick_points(local, area, nu, nt)
        with open(f'{name}.yaml', 'w') as f:
            f.write(scenario_text(name, area, dem_file, origin, starts, targets))
        command = 'plan' if a.plan_only else 'run'
        r = subprocess.run([rl, command] + ([] if a.plan_only else ['--quiet']) +
                           ['--scenario', f'{name}.yaml', '--out', name],
                           capture_output=True, text=True)
        if r.returncode not in (0, 4):
            print(f'| {name} | {command} failed (exit {r.returncode}): '
                  f'{r.stderr.strip().splitlines()[-1] if r.stderr.strip() else ""} |||||||')
            continue
        plan = json.load(open(f'{name}/plan.json'))
        ok = plan['path_source'] == 'optimized'
        optimized += ok
        opt = plan.get('optimizer', {})
        cost = plan.get('cost', {})
        ratio = (f"{cost['objective'] / cost['initial_objective']:.3f}"
                 if cost.get('objective') and cost.get('initial_objective') else '-')
        source = (plan['path_source'] if ok else
                  f"{plan['path_source']}: {plan.get('optimizer_message', '')[:100]}")
        if a.plan_only:
            print(f"| {name} | {dem_label(dem_file, origin)} | {nu} x {nt} | {source} "
                  f"| {opt.get('iterations', '-')} | {plan['solve_time_s']:.2f} | {ratio} | - |")
            sys.stdout.flush()
            continue
        metrics = json.load(open(f'{name}/metrics.json'))
        rows = []
        with open(f'{name}/trajectories.csv') as f:
            f.readline()
            for line in f:
                p = line.split(',')
                rows.append((float(p[2]), float(p[3]), float(p[4])))
        if origin:
            tm = (f'+proj=tmerc +lat_0={origin[0]} +lon_0={origin[1]} +k=1 +x_0=0 +y_0=0 '
                  '+datum=WGS84 +units=m')
            res = sh('gdaltransform', '-s_srs', tm, '-t_srs', 'EPSG:4326', '-output_xy',
                     input=''.join(f'{x} {y}\n' for x, y, _ in rows)).stdout.split('\n')
            src, pts = src_deg, [tuple(map(float, o.split()[:2])) for o in res[:len(rows)]]
        elif dem_file.endswith('.tif'):
            src = Grid(dem_file.replace('.tif', '.asc'))
            w, s = src.x0 - src.cx / 2, src.y0 - src.cy / 2
            pts = [(x + w, y + s) for x, y, _ in rows]
        else:
            src = Grid(dem_file)
            pts = [(x, y) for x, y, _ in rows]
        recheck = min(z - src.height(px, py) for (_, _, z), (px, py) in zip(rows, pts))
        reported = min(u['min_terrain_clearance_m'] for u in metrics['uavs'])
        print(f"| {name} | {dem_label(dem_file, origin)} | {nu} x {nt} | {source} | {opt.get('iterations', '-')} "
              f"| {plan['solve_time_s']:.2f} | {ratio} | {reported:.2f} / {recheck:.2f} |")
        sys.stdout.flush()
    print(f'\n{optimized} of {len(cases)} cases optimized; h_safe {H_SAFE} m')


if __name__ == '__main__':
    try:
        main()
    except subprocess.CalledProcessError as e:
        fail(f"{' '.join(e.cmd[:2])} failed (exit {e.returncode}): {e.stderr.strip()}")
