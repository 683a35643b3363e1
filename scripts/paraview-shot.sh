#!/usr/bin/env bash
# A ParaView screenshot of a VTK trajectory (the README's picture):
#   scripts/paraview-shot.sh [PRESET] [EVERY] [OUT.png]
# runs `carom run --preset PRESET --trajectory <tmp>/run.pvd --every EVERY`, opens the .pvd in
# ParaView's pvpython (under xvfb-run when there is no display), draws every particle as a sphere
# glyph scaled by its `radius`, coloured by speed (|velocity|), goes to the last time step and saves a
# screenshot. Defaults: lecture_mixed_radii, 50, docs/media/paraview.png.
# Needs ParaView with Python (Debian: apt-get install paraview python3-paraview) and, without a
# display, Xvfb. Not part of CI.
set -euo pipefail
out="$(realpath -m "${3:-$(dirname "$0")/../docs/media/paraview.png}")"
cd "$(dirname "$0")/.."
preset="${1:-lecture_mixed_radii}"
every="${2:-50}"
command -v pvpython >/dev/null || {
    echo "paraview-shot: needs pvpython (Debian: apt-get install paraview python3-paraview)" >&2
    exit 2
}
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
cargo build --release -q -p carom-cli
target/release/carom run --preset "$preset" --trajectory "$work/run.pvd" --every "$every"
cat > "$work/shot.py" <<'PY'
import sys
from paraview.simple import *

pvd, out, title = sys.argv[1], sys.argv[2], sys.argv[3]
reader = PVDReader(FileName=pvd)
reader.UpdatePipelineInformation()
last = reader.TimestepValues[-1]
scene = GetAnimationScene()
scene.UpdateAnimationUsingDataTimeSteps()
scene.AnimationTime = last

view = GetActiveViewOrCreate('RenderView')
view.ViewSize = [1200, 1000]
view.ViewTime = last
view.OrientationAxesVisibility = 0
view.UseColorPaletteForBackground = 0
view.Background = [1.0, 1.0, 1.0]

# one sphere per particle, radius = the particle's radius (the glyph's own radius is 0.5)
glyph = Glyph(Input=reader, GlyphType='Sphere')
glyph.ScaleArray = ['POINTS', 'radius']
glyph.ScaleFactor = 2.0
glyph.OrientationArray = ['POINTS', 'No orientation array']
glyph.GlyphMode = 'All Points'
glyph.GlyphType.ThetaResolution = 24
glyph.GlyphType.PhiResolution = 12
shown = Show(glyph, view)
ColorBy(shown, ('POINTS', 'velocity', 'Magnitude'))
lut = GetColorTransferFunction('velocity')
lut.ApplyPreset('Turbo', True)
shown.RescaleTransferFunctionToDataRange(False, True)
shown.SetScalarBarVisibility(view, True)
bar = GetScalarBar(lut, view)
bar.TitleColor = bar.LabelColor = [0.1, 0.1, 0.1]
bar.WindowLocation = 'Lower Center'
bar.Orientation = 'Horizontal'
bar.ScalarBarLength = 0.5
bar.AddRangeLabels = 0
bar.TitleFontSize = bar.LabelFontSize = 18

version = GetParaViewVersion()
frames = len(reader.TimestepValues)
label = Text(Text='%s\nParaView %d.%d: frame %d of %d (t = %g), spheres of the particles\' '
                  'radii, coloured by speed' % (title, version.major, version.minor,
                                                     frames, frames, last))
label_shown = Show(label, view)
label_shown.Color = [0.1, 0.1, 0.1]
label_shown.FontSize = 14
label_shown.Justification = 'Left'
label_shown.WindowLocation = 'Upper Left Corner'

# fit the particles (a 2D view looks along -z; a 3D scene is seen from the same side)
view.InteractionMode = '2D'
ResetCamera(view)
x0, x1, y0, y1, z0, z1 = glyph.GetDataInformation().GetBounds()
aspect = 1200.0 / 1000.0
view.CameraFocalPoint = [(x0 + x1) / 2, (y0 + y1) / 2 - 0.05 * (y1 - y0), (z0 + z1) / 2]
view.CameraPosition = [(x0 + x1) / 2, (y0 + y1) / 2 - 0.05 * (y1 - y0), z1 + 10 * (x1 - x0)]
view.CameraViewUp = [0, 1, 0]
view.CameraParallelScale = 0.5 * max(y1 - y0, (x1 - x0) / aspect) * 1.3
Render(view)
bar.Title = 'speed'
bar.ComponentTitle = ''
Render(view)
SaveScreenshot(out, view, ImageResolution=[1200, 1000], TransparentBackground=0)
print('wrote %s: ParaView %d.%d, %d frames, t = %g' % (out, version.major, version.minor,
                                                        frames, last))
PY
title="carom run --preset $preset --trajectory run.pvd --every $every"
pv=(pvpython --force-offscreen-rendering)
if [ -z "${DISPLAY:-}" ]; then
    pv=(xvfb-run -a -s "-screen 0 1280x1024x24" "${pv[@]}")
fi
"${pv[@]}" "$work/shot.py" "$work/run.pvd" "$out" "$title"
