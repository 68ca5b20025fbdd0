"""Draws the report's 3D pictures with VTK (kinds "network", "grains" and "surfaces" of charts.json; docs/report.md).

A network chart holds `segments` (x0, y0, z0, x1, y1, z1 per contact, metres) and `force` (the
normal force of each, N). Each contact is a tube of radius radius_max * force / force_max (at most
1.5 radius_max, at least 2 % of it), coloured by force on one scale from 0 to force_max (viridis).

A grains chart holds each grain's `centre`, `radius` and `value`: the `highlighted` grains are
spheres painted on the scale colour_min .. colour_max (logarithmic when colour_log, plasma, as the
sections' D2min; else viridis, as their eps_q), a highlighted grain whose value is null grey; the
others grey points; the `membrane` balls pale blue points.

A surfaces chart names `mesh_file`, an HDF5 file beside charts.json (the report writes it and
removes it once drawn): /vertices (V x 3, m), /triangles (T x 3) and /label (T), each triangle
coloured by its grain's label as the sections colour it; the `membrane` balls are pale blue
spheres of `membrane_radius` (points when 0).

All are seen by a fixed parallel camera looking along +y from 20 degrees above, framing `bounds`.
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

import h5py
import matplotlib
import numpy as np

from report_sections import identity_colours

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


def spheres(vtk, data, radius, theta, phi):
    """A sphere of `radius` (theta x phi facets) on every point of `data`."""
    sphere = vtk.vtkSphereSource()
    sphere.SetRadius(radius)
    sphere.SetThetaResolution(theta)
    sphere.SetPhiResolution(phi)
    glyphs = vtk.vtkGlyph3D()
    glyphs.SetInputData(data)
    glyphs.SetSourceConnection(sphere.GetOutputPort())
    return glyphs


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
    """The actors and the colour bar (if any) seen by the fixed camera, written as a PNG."""
    renderer = vtk.vtkRenderer()
    renderer.SetBackground(1.0, 1.0, 1.0)
    for actor in actors:
        renderer.AddActor(actor)
    if bar is not None:
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
    table = lookup_table(vtk, lo, hi, g["colour_log"], "plasma" if g["colour_log"] else "viridis")
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
        # Fewer facets when there are many spheres (every grain of a 15 000-grain sample, eps_q):
        # at about 15 pixels a sphere, 8 x 6 facets look as round and cost a fifth.
        glyphs = spheres(vtk, data, 1.0, *((16, 12) if shown.sum() < 3000 else (8, 6)))
        glyphs.SetScaleModeToScaleByScalar()
        glyphs.SetScaleFactor(1.0)
        glyphs.SetColorModeToColorByScalar()
        actors.append(coloured(vtk, glyphs, "value", table))
    margin = float(radius.max()) if len(radius) else 0.0
    render(vtk, actors, colour_bar(vtk, table, g["quantity"]), chart["title"], g["bounds"], margin, out_path)


def draw_surfaces(chart, out_path):
    start_display()
    import vtk  # after the display exists: VTK's X window reads DISPLAY
    from vtk.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray

    s = chart["surfaces"]
    mesh_path = os.path.join(os.path.dirname(out_path), s["mesh_file"])
    try:
        with h5py.File(mesh_path, "r") as f:
            vertices = np.ascontiguousarray(f["vertices"][:], dtype=np.float64)
            triangles = np.asarray(f["triangles"][:], dtype=np.int64)
            label = np.asarray(f["label"][:], dtype=np.int64)
    except (OSError, KeyError) as e:
        sys.exit(f"cannot read the grains' triangles {mesh_path} ({e.__class__.__name__}): the report writes them beside "
                 "charts.json just before drawing, rerun it")
    points = vtk.vtkPoints()
    points.SetData(numpy_to_vtk(vertices, deep=True))
    cells = vtk.vtkCellArray()
    offsets = np.arange(0, 3 * len(triangles) + 1, 3, dtype=np.int64)
    cells.SetData(numpy_to_vtkIdTypeArray(offsets, deep=True), numpy_to_vtkIdTypeArray(triangles.ravel(), deep=True))
    data = vtk.vtkPolyData()
    data.SetPoints(points)
    data.SetPolys(cells)
    colours = numpy_to_vtk((255 * identity_colours(label)).astype(np.uint8), deep=True)
    colours.SetName("colour")
    data.GetCellData().SetScalars(colours)
    mapper = vtk.vtkPolyDataMapper()
    mapper.SetInputData(data)
    mapper.SetScalarModeToUseCellData()
    mapper.SetColorModeToDirectScalars()
    grains = vtk.vtkActor()
    grains.SetMapper(mapper)
    actors = [grains]
    if s["membrane"]:
        if s["membrane_radius"] > 0:
            balls = vtk.vtkPolyData()
            balls.SetPoints(points_of(vtk, s["membrane"]))
            glyphs = spheres(vtk, balls, s["membrane_radius"], 8, 6)
            glyphs.ScalingOff()
            membrane_mapper = vtk.vtkPolyDataMapper()
            membrane_mapper.SetInputConnection(glyphs.GetOutputPort())
            membrane = vtk.vtkActor()
            membrane.SetMapper(membrane_mapper)
            membrane.GetProperty().SetColor(0.6, 0.75, 0.95)
            actors.append(membrane)
        else:
            actors.append(point_cloud(vtk, s["membrane"], (0.6, 0.75, 0.95), 2))
    render(vtk, actors, None, chart["title"], s["bounds"], 0.0, out_path)
