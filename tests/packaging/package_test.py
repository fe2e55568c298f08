#!/usr/bin/env python3
"""The Debian package of a rig PC, built, installed by dpkg and run.

  package_test.py BUILD_DIR WORK_DIR

Builds the package with `cpack -G DEB` from BUILD_DIR, checks its control
fields and contents, checks that every run-time dependency it declares is
installed on this machine, installs it with dpkg into a root of its own
under WORK_DIR (its own dpkg database: the machine's packages are never
touched) and runs the main job, `kcrig campaign`, from the installed
binary in a folder outside the source tree. The installed plant.yaml is
edited first (c_O1 3600 -> 3200 N/mm), so the campaign finding 3200 N/mm
proves the binary reads the configuration installed beside it; a copy of
the binary without its share/ must refuse in one line, not read the build
machine's config. The package declares the package of every file the
binary reads at run time (plotly.js for the report). Finally the package
is purged and must leave no file behind.
Python 3 standard library only; dpkg, dpkg-deb and cpack from the machine.
"""
import json
import pathlib
import re
import shutil
import subprocess
import sys
import tempfile

CONTENTS = [
    'usr/bin/kcrig',
    'usr/share/kcrig/config/model.yaml',
    'usr/share/kcrig/config/experiment.yaml',
    'usr/share/kcrig/config/rig.yaml',
    'usr/share/kcrig/config/plant.yaml',
    'usr/share/kcrig/config/kc_rig.dbc',
    'usr/share/kcrig/config/modbus_map.yaml',
    'usr/share/doc/kcrig/README.md',
    'usr/share/doc/kcrig/docs/rig.md',
    'usr/share/doc/kcrig/estimator/README.md',
]
TRUE_C_O1 = 3.2e6


def run(args, **kwargs):
    result = subprocess.run(args, capture_output=True, text=True, **kwargs)
    if result.returncode != 0:
        sys.exit(f'{" ".join(map(str, args))}: exit {result.returncode}\n'
                 f'{result.stdout}{result.stderr}')
    return result.stdout


def build_package(build_dir, work):
    out = work / 'package'
    run(['cpack', '-G', 'DEB', '-B', str(out)], cwd=build_dir)
    debs = list(out.glob('kcrig_*.deb'))
    if len(debs) != 1:
        sys.exit(f'cpack wrote {len(debs)} kcrig_*.deb in {out}')
    return debs[0]


def check_control(deb, build_dir):
    fields = {f: run(['dpkg-deb', '-f', str(deb), f]).strip()
              for f in ('Package', 'Version', 'Architecture', 'Depends')}
    print('control:', fields)
    assert fields['Package'] == 'kcrig', fields
    for lib in ('libmodbus5', 'libyaml-cpp0.7', 'libstdc++6'):
        assert lib in fields['Depends'], f'Depends lacks {lib}'
    # What the binary reads at run time beyond its libraries: the report
    # inlines plotly.js from the path it was built with.
    plotly = re.search(r'KCRIG_PLOTLY_JS:FILEPATH=(.*)',
                       (build_dir / 'CMakeCache.txt').read_text()).group(1)
    owner = run(['dpkg-query', '-S', plotly]).split(':')[0]
    assert owner in fields['Depends'], f'Depends lacks {owner} ({plotly})'
    # Every dependency satisfiable here: one alternative of each installed.
    for group in fields['Depends'].split(','):
        names = [re.sub(r'\s*\(.*\)', '', a).strip()
                 for a in group.split('|')]
        if not any(installed(n) for n in names):
            sys.exit(f'dependency {group.strip()} is not installed')


def installed(package):
    # One line per architecture the package is installed for.
    result = subprocess.run(
        ['dpkg-query', '-W', '-f=${Status}\\n', package],
        capture_output=True, text=True)
    return 'install ok installed' in result.stdout.splitlines()


def check_contents(deb):
    listed = {line.split()[-1].lstrip('./')
              for line in run(['dpkg-deb', '-c', str(deb)]).splitlines()}
    for path in CONTENTS:
        assert path in listed, f'{deb.name} lacks {path}'


def install(deb, root):
    admin = root / 'var/lib/dpkg'
    for sub in ('info', 'updates', 'triggers'):
        (admin / sub).mkdir(parents=True)
    (admin / 'status').touch()
    (admin / 'available').touch()
    # This root's database knows no library: the dependencies were checked
    # against the machine's above.
    run(['dpkg', f'--root={root}', '--force-depends', '--force-not-root',
         '--log=/dev/null', '-i', str(deb)])
    status = run(['dpkg-query', f'--admindir={admin}', '-W',
                  '-f=${Status}', 'kcrig'])
    assert status == 'install ok installed', status


def run_main_job(root, work):
    plant = root / 'usr/share/kcrig/config/plant.yaml'
    text = plant.read_text()
    edited = re.sub(r'(\n\s*c_O1:\s*)3\.6e6', rf'\g<1>{TRUE_C_O1:g}', text)
    assert edited != text, 'plant.yaml: no c_O1: 3.6e6 to edit'
    plant.write_text(edited)
    job = work / 'job'
    job.mkdir()
    output = run([str(root / 'usr/bin/kcrig'), 'campaign', '--quiet',
                  '--out', 'out/campaign'], cwd=job)
    print(output)
    folder = job / 'out/campaign'
    assert (folder / 'report.html').is_file(), 'no report.html'
    campaign = json.loads((folder / 'campaign.json').read_text())
    c_o1 = next(p for p in campaign['iterations'][-1]['parameters']
                if p['name'] == 'c_O1')
    low, high = c_o1['ci95']
    print(f'c_O1 {c_o1["value"]:.0f} N/m, 95 % [{low:.0f}, {high:.0f}]')
    assert abs(c_o1['value'] - TRUE_C_O1) < 0.01 * TRUE_C_O1, c_o1


def run_copied_binary(root):
    """A copy of the binary without its share/ finds no config: one line
    naming where it looked, never the build machine's source config."""
    with tempfile.TemporaryDirectory() as lonely:
        copy = pathlib.Path(lonely) / 'bin' / 'kcrig'
        copy.parent.mkdir()
        shutil.copy2(root / 'usr/bin/kcrig', copy)
        result = subprocess.run(
            [str(copy), 'simulate', '--out', str(pathlib.Path(lonely) /
                                                  'run.csv')],
            capture_output=True, text=True, cwd=lonely)
        where = str(pathlib.Path(lonely) / 'share/kcrig/config')
        assert result.returncode == 1, result
        assert f'{where}: config directory not found' in result.stderr, \
            result.stderr


def purge(root):
    run(['dpkg', f'--root={root}', '--force-not-root', '--log=/dev/null',
         '--purge', 'kcrig'])
    left = [p for p in (root / 'usr').rglob('*') if p.is_file()]
    assert not left, f'left after --purge: {left}'


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    build_dir = pathlib.Path(sys.argv[1]).resolve()
    work = pathlib.Path(sys.argv[2]).resolve()
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    deb = build_package(build_dir, work)
    check_control(deb, build_dir)
    check_contents(deb)
    root = work / 'root'
    install(deb, root)
    run_main_job(root, work)
    run_copied_binary(root)
    purge(root)
    shutil.rmtree(work)
    print('package: built, installed, ran the main job, purged')


if __name__ == '__main__':
    main()
