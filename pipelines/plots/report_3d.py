"""Draws the report's 3D pictures with VTK (kinds "network" and "grains" of charts.json; docs/report.md).

A network chart holds `segments` (x0, y0, z0, x1, y1, z1 per contact, metres) and `force` (the
normal force of each, N). Each contact is a tube of radius radius_max * force / force_max (at most
1.5 radius_max, at least 2 % of it), coloured by force on one scale from 0 to force_max (viridis).

A grains chart holds each grain's `centre`, `radius` and `value`: the `highlighted` grains are
spheres painted on the scale colour_min .. colour_max (logarithmic when colour_log, plasma, as the
sections' D2min), a highlighted grain whose value is null grey; the others grey points; the
`membrane` balls pale blue points.

Both are seen by a fixed parallel camera looking along +y from 20 degrees above, framing `bounds`.
The script computes nothing but radii and colours: every number comes from the JSON.

VTK (Debian's python3-vtk9) renders on its own X server: Xvfb, started here on a free display
and killed with this process (and so with the report), so the pictures are rendered the same way
(Mesa's software renderer) on every machine, with or without a screen.
"""
import atexit
import ctypes
import math
import os
import signal
import subprocess
import sys

import matplotlib
import numpy as np

XVFB = "/usr/bin/Xvfb"
SIZE = 640  # pixels, square
_display = None


def start_display():
    """A private Xvfb for VTK (once per run), which dies with this process (PR_SET_PDEATHSIG).

    -noreset: by default an X server resets when its last client leaves, and every picture's
    window is a client that leaves; the next window, connecting during the reset, would be
    refused ("bad X server connection") now and then.
    """
    global _display
    if _display is not None:
        return
    if not os.path.exists(XVFB):
        sys.exit(f"{XVFB} is missing: the 3D pictures need Debian's xvfb (scripts/deps.sh installs it)")
    libc = ctypes.CDLL("libc.so.6", use_errno=True)
    read_fd, write_fd = os.pipe()
    _display = subprocess.Popen([XVFB, "-displayfd", str(write_fd), "-screen", "0", f"{SIZE}x{SIZE}x24", "-nolisten", "tcp",
                                 "-noreset"], pass_fds=(write_fd,), preexec_fn=lambda: libc.prctl(1, signal.SIGKILL),
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(write_fd)
    number = b""
    while not number.endswith(b"\n"):
        c = os.read(read_fd, 1)
        if not c:
            sys.exit(f"{XVFB} did not start: the 3D pictures need a working Xvfb (Debian's xvfb)")
        number += c
    os.close(read_fd)
    os.environ["DISPLAY"] = ":" + number.decode().strip()
    atexit.register(stop_display)


def stop_display():
    _display.terminate()
    _display.wait()


def lookup_table(vtk, lo, hi, log, name):
    table = vtk.vtkLookupTable()
    table.SetNumberOfTableValues(256)
    table.SetRange(lo, hi)
    if log:
        table.SetScaleToLog10()
    for i, rgba in enumerate(matplotlib.colormaps[name](np.linspace(0.0, 1.0, 256))):
        table.SetTableValue(i, *rgba)
    table.Build()
    return table


def points_of(vtk, xyz):
    points = vtk.vtkPoints()
    for p in np.asarray(xyz, dtype=np.float64).reshape(-1, 3):
        points.InsertNextPoint(*p)
    return points


def point_cloud(vtk, xyz, colour, size):
    """Grey (or any) points of a fixed size in pixels."""
    data = vtk.vtkPolyData()
    data.SetPoints(points_of(vtk, xyz))
    vertices = vtk.vtkVertexGlyphFilter()
    vertices.SetInputData(data)
    mapper = vtk.vtkPolyDataMapper()
    mapper.SetInputConnection(vertices.GetOutputPort())
    actor = vtk.vtkActor()
    actor.SetMapper(mapper)
    actor.GetProperty().SetColor(*colour)
    actor.GetProperty().SetPointSize(size)
    return actor


def coloured(vtk, source, array, table):
    """An actor of `source`'s output painted by its point array `array` through `table`."""
    mapper = vtk.vtkPolyDataMapper()
    mapper.SetInputConnection(source.GetOutputPort())
    mapper.SetScalarModeToUsePointFieldData()
    mapper.SelectColorArray(array)
    mapper.SetLookupTable(table)
    mapper.UseLookupTableScalarRangeOn()
    actor = vtk.vtkActor()
    actor.SetMapper(mapper)
    return actor


def colour_bar(vtk, table, title):
    bar = vtk.vtkScalarBarActor()
    bar.SetLookupTable(table)
    bar.SetTitle(title)
    bar.SetNumberOfLabels(5)
    bar.SetPosition(0.86, 0.1)
    bar.SetWidth(0.1)
    bar.SetHeight(0.8)
    for text in (bar.GetTitleTextProperty(), bar.GetLabelTextProperty()):
        text.SetColor(0.1, 0.1, 0.1)
        text.SetFontSize(12)
        text.ItalicOff()
        text.BoldOff()
    bar.UnconstrainedFontSizeOn()
    return bar


def render(vtk, actors, bar, title, bounds, margin, out_path):
    """The actors and the colour bar seen by the fixed camera, written as a PNG."""
    renderer = vtk.vtkRenderer()
    renderer.SetBackground(1.0, 1.0, 1.0)
    for actor in actors:
        renderer.AddActor(actor)
    renderer.AddActor2D(bar)
    text = vtk.vtkTextActor()
    text.SetInput(title)
    text.GetTextProperty().SetColor(0.1, 0.1, 0.1)
    text.GetTextProperty().SetFontSize(14)
    text.SetPosition(10, SIZE - 24)
    renderer.AddActor2D(text)
    # Parallel projection along +y, 20 degrees above, on the bounds' centre, the scene left of the bar.
    x0, x1, y0, y1, z0, z1 = bounds
    centre = np.array([(x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2])
    span = max(x1 - x0, y1 - y0, z1 - z0) + 2 * margin
    up = math.radians(20.0)
    camera = renderer.GetActiveCamera()
    camera.ParallelProjectionOn()
    camera.SetFocalPoint(*centre)
    camera.SetPosition(*(centre + 10 * span * np.array([0.0, -math.cos(up), math.sin(up)])))
    camera.SetViewUp(0.0, 0.0, 1.0)
    camera.SetParallelScale(0.62 * span)
    camera.SetClippingRange(5 * span, 15 * span)
    camera.SetWindowCenter(0.12, 0.0)

    window = vtk.vtkRenderWindow()
    window.SetOffScreenRendering(1)
    window.SetSize(SIZE, SIZE)
    window.AddRenderer(renderer)
    window.Render()
    image = vtk.vtkWindowToImageFilter()
    image.SetInput(window)
    image.Update()
    writer = vtk.vtkPNGWriter()
    writer.SetFileName(out_path)
    writer.SetInputConnection(image.GetOutputPort())
    writer.Write()
    window.Finalize()
    if not os.path.isfile(out_path):  # VTK's writer logs its errors without raising them
        sys.exit(f"VTK could not write {out_path}; check that its folder exists and the disk has room")


def draw_network(chart, out_path):
    start_display()
    import vtk  # after the display exists: VTK's X window reads DISPLAY

    net = chart["network"]
    ends = np.asarray(net["segments"], dtype=np.float64).reshape(-1, 3)
    force = np.repeat(np.asarray(net["force"], dtype=np.float64), 2)
    top, radius_max = net["force_max"], net["radius_max"]
    radius = radius_max * np.clip(force / top, 0.02, 1.5)
    radii = vtk.vtkDoubleArray()
    forces = vtk.vtkDoubleArray()
    forces.SetName("force")
    lines = vtk.vtkCellArray()
    for i in range(len(ends)):
        radii.InsertNextValue(radius[i])
        forces.InsertNextValue(force[i])
    for i in range(0, len(ends), 2):
        lines.InsertNextCell(2)
        lines.InsertCellPoint(i)
        lines.InsertCellPoint(i + 1)
    data = vtk.vtkPolyData()
    data.SetPoints(points_of(vtk, ends))
    data.SetLines(lines)
    data.GetPointData().SetScalars(radii)
    data.GetPointData().AddArray(forces)
    tubes = vtk.vtkTubeFilter()
    tubes.SetInputData(data)
    tubes.SetVaryRadiusToVaryRadiusByAbsoluteScalar()
    tubes.SetNumberOfSides(8)
    tubes.CappingOn()
    table = lookup_table(vtk, 0.0, top, False, "viridis")
    actor = coloured(vtk, tubes, "force", table)
    render(vtk, [actor], colour_bar(vtk, table, "normal force (N)"), chart["title"], net["bounds"], radius_max, out_path)


def draw_grains(chart, out_path):
    start_display()
    import vtk  # after the display exists: VTK's X window reads DISPLAY

    g = chart["grains"]
    centre = np.asarray(g["centre"], dtype=np.float64).reshape(-1, 3)
    radius = np.asarray(g["radius"], dtype=np.float64)
    value = np.array([np.nan if v is None else v for v in g["value"]], dtype=np.float64)
    shown = np.asarray(g["highlighted"], dtype=bool)
    lo, hi = g["colour_min"], g["colour_max"]
    if lo is None or hi is None:
        lo, hi = 1.0, 10.0
    table = lookup_table(vtk, lo, hi, g["colour_log"], "plasma")
    table.SetNanColor(0.78, 0.78, 0.78, 1.0)
    actors = [point_cloud(vtk, centre[~shown], (0.55, 0.55, 0.55), 2)]
    if g["membrane"]:
        actors.append(point_cloud(vtk, g["membrane"], (0.6, 0.75, 0.95), 1))
    if shown.any():
        scales = vtk.vtkDoubleArray()
        scales.SetName("radius")
        values = vtk.vtkDoubleArray()
        values.SetName("value")
        for r, v in zip(radius[shown], value[shown]):
            scales.InsertNextValue(r)
            values.InsertNextValue(max(v, lo) if np.isfinite(v) and g["colour_log"] else v)
        data = vtk.vtkPolyData()
        data.SetPoints(points_of(vtk, centre[shown]))
        data.GetPointData().SetScalars(scales)
        data.GetPointData().AddArray(values)
        sphere = vtk.vtkSphereSource()
        sphere.SetRadius(1.0)
        sphere.SetThetaResolution(16)
        sphere.SetPhiResolution(12)
        glyphs = vtk.vtkGlyph3D()
        glyphs.SetInputData(data)
        glyphs.SetSourceConnection(sphere.GetOutputPort())
        glyphs.SetScaleModeToScaleByScalar()
        glyphs.SetScaleFactor(1.0)
        glyphs.SetColorModeToColorByScalar()
        actors.append(coloured(vtk, glyphs, "value", table))
    margin = float(radius.max()) if len(radius) else 0.0
    render(vtk, actors, colour_bar(vtk, table, g["quantity"]), chart["title"], g["bounds"], margin, out_path)
