"""Draws the report's 3D force-chain pictures (kind "network" of charts.json; docs/report.md).

A network chart holds `segments` (x0, y0, z0, x1, y1, z1 per contact, metres) and `force` (the
normal force of each, N). Each contact is a tube of radius radius_max * force / force_max (at most
1.5 radius_max, at least 2 % of it), coloured by force on one scale from 0 to force_max (viridis),
seen by a fixed parallel camera looking along +y from 20 degrees above, framing `bounds`. The
script computes nothing but the tubes' radii and colours: every number comes from the JSON.

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
    """A private Xvfb for VTK (once per run), which dies with this process (PR_SET_PDEATHSIG)."""
    global _display
    if _display is not None:
        return
    if not os.path.exists(XVFB):
        sys.exit(f"{XVFB} is missing: the 3D pictures need Debian's xvfb (scripts/deps.sh installs it)")
    libc = ctypes.CDLL("libc.so.6", use_errno=True)
    read_fd, write_fd = os.pipe()
    _display = subprocess.Popen([XVFB, "-displayfd", str(write_fd), "-screen", "0", f"{SIZE}x{SIZE}x24", "-nolisten", "tcp"],
                                pass_fds=(write_fd,), preexec_fn=lambda: libc.prctl(1, signal.SIGKILL),
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


def lookup_table(vtk, top):
    table = vtk.vtkLookupTable()
    table.SetNumberOfTableValues(256)
    table.SetRange(0.0, top)
    for i, rgba in enumerate(matplotlib.colormaps["viridis"](np.linspace(0.0, 1.0, 256))):
        table.SetTableValue(i, *rgba)
    table.Build()
    return table


def draw(chart, out_path):
    start_display()
    import vtk  # after the display exists: VTK's X window reads DISPLAY

    net = chart["network"]
    ends = np.asarray(net["segments"], dtype=np.float64).reshape(-1, 3)
    force = np.repeat(np.asarray(net["force"], dtype=np.float64), 2)
    top, radius_max = net["force_max"], net["radius_max"]
    radius = radius_max * np.clip(force / top, 0.02, 1.5)

    points = vtk.vtkPoints()
    lines = vtk.vtkCellArray()
    radii = vtk.vtkDoubleArray()
    forces = vtk.vtkDoubleArray()
    forces.SetName("force")
    for i, p in enumerate(ends):
        points.InsertNextPoint(*p)
        radii.InsertNextValue(radius[i])
        forces.InsertNextValue(force[i])
    for i in range(0, len(ends), 2):
        lines.InsertNextCell(2)
        lines.InsertCellPoint(i)
        lines.InsertCellPoint(i + 1)
    data = vtk.vtkPolyData()
    data.SetPoints(points)
    data.SetLines(lines)
    data.GetPointData().SetScalars(radii)
    data.GetPointData().AddArray(forces)
    tubes = vtk.vtkTubeFilter()
    tubes.SetInputData(data)
    tubes.SetVaryRadiusToVaryRadiusByAbsoluteScalar()
    tubes.SetNumberOfSides(8)
    tubes.CappingOn()
    table = lookup_table(vtk, top)
    mapper = vtk.vtkPolyDataMapper()
    mapper.SetInputConnection(tubes.GetOutputPort())
    mapper.SetScalarModeToUsePointFieldData()
    mapper.SelectColorArray("force")
    mapper.SetLookupTable(table)
    mapper.UseLookupTableScalarRangeOn()
    actor = vtk.vtkActor()
    actor.SetMapper(mapper)

    renderer = vtk.vtkRenderer()
    renderer.SetBackground(1.0, 1.0, 1.0)
    renderer.AddActor(actor)
    bar = vtk.vtkScalarBarActor()
    bar.SetLookupTable(table)
    bar.SetTitle("normal force (N)")
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
    renderer.AddActor2D(bar)
    title = vtk.vtkTextActor()
    title.SetInput(chart["title"])
    title.GetTextProperty().SetColor(0.1, 0.1, 0.1)
    title.GetTextProperty().SetFontSize(14)
    title.SetPosition(10, SIZE - 24)
    renderer.AddActor2D(title)

    # The fixed camera: parallel projection along +y, 20 degrees above, on the bounds' centre; the
    # picture's left 85 % holds the bounds.
    x0, x1, y0, y1, z0, z1 = net["bounds"]
    centre = np.array([(x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2])
    span = max(x1 - x0, y1 - y0, z1 - z0) + 2 * radius_max
    up = math.radians(20.0)
    camera = renderer.GetActiveCamera()
    camera.ParallelProjectionOn()
    camera.SetFocalPoint(*centre)
    camera.SetPosition(*(centre + 10 * span * np.array([0.0, -math.cos(up), math.sin(up)])))
    camera.SetViewUp(0.0, 0.0, 1.0)
    camera.SetParallelScale(0.62 * span)
    camera.SetClippingRange(5 * span, 15 * span)
    renderer.SetViewport(0.0, 0.0, 1.0, 1.0)
    camera.SetWindowCenter(0.12, 0.0)  # the scene left of the colour bar

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
