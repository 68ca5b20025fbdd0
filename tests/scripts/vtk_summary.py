"""Reads a VTK XML file with VTK's own reader (what ParaView uses) and prints a JSON summary:
point and cell counts, array names with component counts and value ranges, and the bounds.
Usage: vtk_summary.py FILE.vtp|FILE.vtu"""
import json
import sys

import vtk  # Debian python3-vtk9

path = sys.argv[1]
reader = vtk.vtkXMLPolyDataReader() if path.endswith(".vtp") else vtk.vtkXMLUnstructuredGridReader()
reader.SetFileName(path)
reader.Update()
if reader.GetErrorCode() != 0:
    sys.exit(f"VTK could not read {path}")
data = reader.GetOutput()


def arrays(fields):
    out = {}
    for i in range(fields.GetNumberOfArrays()):
        a = fields.GetArray(i)
        out[a.GetName()] = {"components": a.GetNumberOfComponents(), "tuples": a.GetNumberOfTuples(),
                            "range": list(a.GetRange(-1 if a.GetNumberOfComponents() > 1 else 0))}
    return out


summary = {"points": data.GetNumberOfPoints(), "cells": data.GetNumberOfCells(), "bounds": list(data.GetBounds()),
           "point_data": arrays(data.GetPointData()), "cell_data": arrays(data.GetCellData())}
if path.endswith(".vtp"):
    summary.update(verts=data.GetNumberOfVerts(), lines=data.GetNumberOfLines(), polys=data.GetNumberOfPolys())
else:
    # VTK's own cell volumes (quadratic cells split through their mid-edge nodes): a wrong node
    # order shows up as a wrong total.
    sizes = vtk.vtkCellSizeFilter()
    sizes.SetInputData(data)
    sizes.ComputeVertexCountOff()
    sizes.ComputeLengthOff()
    sizes.ComputeAreaOff()
    sizes.Update()
    volumes = sizes.GetOutput().GetCellData().GetArray("Volume")
    summary["volume"] = sum(volumes.GetValue(i) for i in range(volumes.GetNumberOfTuples()))
print(json.dumps(summary))
