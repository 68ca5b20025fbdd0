"""Draws the report's section charts (kind "section" of charts.json; docs/report.md, "Sections").

A section chart holds one or more views side by side. A view is a plane through the sample
("xz": vertical, y = offset; "xy": horizontal, z = offset) drawn in the frame `extent` (u0, u1, v0,
v1, metres) that both sides of a panel share, as either
- a slice of a label image: `labels_file`'s /labels at `index` across the plane (kind=labels,
  docs/formats.md), over the grey values of `volume_file`'s /volume when one is named; or
- the twin's outlines: `outline` (closed polygons u0, v0, u1, v1, ... in metres), grain
  `outline_label` each.
Grains are filled with the colour of their identity (`identity_label` -> `identity`, else their own
label: a fixed hue per label), or, when `quantity` is set, painted with their value
(`value_label` -> `value`, null = not defined, drawn grey) on the fixed colour scale colour_min ..
colour_max (logarithmic when colour_log). The script computes nothing but colours: which slice,
which grains and which values all come from the JSON.
"""
import h5py
import matplotlib
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import PolyCollection
from matplotlib.colors import LogNorm, Normalize, hsv_to_rgb

UNDEFINED = np.array([0.78, 0.78, 0.78])  # a painted grain whose value is not defined
EMPTY = np.array([1.0, 1.0, 1.0])        # no grain, and no grey image under it
BOUNDARY = np.array([0.1, 0.1, 0.1])


def identity_colours(labels):
    """A fixed colour per label: hues spread by the golden ratio, so neighbours differ."""
    labels = np.asarray(labels, dtype=np.float64)
    hsv = np.stack([np.mod(labels * 0.6180339887, 1.0), 0.45 + 0.3 * np.mod(labels * 0.381966, 1.0),
                    np.full_like(labels, 0.95)], axis=-1)
    return hsv_to_rgb(hsv)


def label_lookup(view, max_label):
    """Colour of every label 0..max_label (0, no grain, is EMPTY); with the norm and colour map when painted."""
    if view["quantity"]:
        lo, hi = view["colour_min"], view["colour_max"]
        if lo is None or hi is None:
            lo, hi = (1.0, 10.0) if view["colour_log"] else (0.0, 1.0)
        # Values beyond the scale take its end colours (a D2min of 0 is the lowest on a log scale).
        norm = LogNorm(lo, hi, clip=True) if view["colour_log"] else Normalize(lo, hi, clip=True)
        cmap = matplotlib.colormaps["plasma" if view["colour_log"] else "viridis"]
        colours = np.tile(UNDEFINED, (max_label + 1, 1))
        labels = np.asarray(view["value_label"], dtype=np.int64)
        values = np.array([np.nan if v is None else v for v in view["value"]], dtype=np.float64)
        shown = (labels <= max_label) & np.isfinite(values)
        values = np.maximum(values[shown], lo) if view["colour_log"] else values[shown]
        colours[labels[shown]] = cmap(norm(values))[:, :3]
        colours[0] = EMPTY
        return colours, norm, cmap
    identity = np.arange(max_label + 1)
    labels = np.asarray(view["identity_label"], dtype=np.int64)
    shown = labels <= max_label
    identity[labels[shown]] = np.asarray(view["identity"], dtype=np.int64)[shown]
    colours = identity_colours(identity)
    colours[0] = EMPTY
    return colours, None, None


def image_slice(path, dataset, plane, index):
    """The slice of an image dataset across the plane, rows along v, and its (u0, u1, v0, v1) extent."""
    with h5py.File(path, "r") as f:
        d = f[dataset]
        dz, dy, dx = d.attrs["voxel_size"]
        oz, oy, ox = d.attrs["origin"]
        nz, ny, nx = d.shape
        u = (ox - dx / 2, ox + (nx - 0.5) * dx)
        if plane == "xz":
            return d[:, index, :], u + (oz - dz / 2, oz + (nz - 0.5) * dz)
        return d[index, :, :], u + (oy - dy / 2, oy + (ny - 0.5) * dy)


def boundaries(labels):
    """Pixels where the label changes to a neighbour's, on either side of a grain's edge."""
    edge = np.zeros(labels.shape, dtype=bool)
    across = labels[:, 1:] != labels[:, :-1]
    edge[:, 1:] |= across
    edge[:, :-1] |= across
    across = labels[1:, :] != labels[:-1, :]
    edge[1:, :] |= across
    edge[:-1, :] |= across
    return edge


def draw_image_view(ax, view):
    labels, extent = image_slice(view["labels_file"], "labels", view["plane"], view["index"])
    labels = labels.astype(np.int64)
    colours, norm, cmap = label_lookup(view, int(labels.max()))
    rgb = colours[labels]
    if view["volume_file"]:
        grey, _ = image_slice(view["volume_file"], "volume", view["plane"], view["index"])
        grey = grey.astype(np.float64)
        lo, hi = np.percentile(grey, [0.5, 99.5])
        grey = np.clip((grey - lo) / ((hi - lo) or 1.0), 0.0, 1.0)[..., None]
        grain = (labels > 0)[..., None]
        # Grains tinted over their grey values (painted ones in their exact colour, to read against
        # the colour bar); the pores show the scan as it is.
        tinted = rgb if view["quantity"] else 0.45 * grey + 0.55 * rgb
        rgb = np.where(grain, tinted, grey * np.ones(3))
    rgb[boundaries(labels) & (labels > 0)] = BOUNDARY
    ax.imshow(rgb, origin="lower", extent=[1e3 * e for e in extent], interpolation="nearest")
    return norm, cmap


def draw_outline_view(ax, view):
    labels = view["outline_label"]
    max_label = max(labels) if labels else 0
    colours, norm, cmap = label_lookup(view, max_label)
    polygons = [1e3 * np.asarray(flat).reshape(-1, 2) for flat in view["outline"]]
    ax.add_collection(PolyCollection(polygons, facecolors=[colours[label] for label in labels], edgecolors=BOUNDARY,
                                     linewidths=0.3))
    ax.set_facecolor(EMPTY)
    return norm, cmap


def draw(chart, out_path):
    views = chart["sections"]
    aspects = [max((v["extent"][1] - v["extent"][0]) / (v["extent"][3] - v["extent"][2]), 0.2) for v in views]
    # Tall samples (a vertical section higher than wide) get a taller picture, so their grains stay legible.
    height = 4.2 if min(aspects) >= 0.75 else 6.0
    width = min(max(sum(aspects) * (height - 0.9) + 1.6 * len(views) + (1.0 if views[0]["quantity"] else 0.0), 4.0), 11.0)
    fig, axes = plt.subplots(1, len(views), figsize=(width, height), dpi=100, squeeze=False,
                             gridspec_kw={"width_ratios": aspects}, layout="constrained")
    mappable = None
    for ax, view in zip(axes[0], views):
        draw_view = draw_image_view if view["labels_file"] else draw_outline_view
        norm, cmap = draw_view(ax, view)
        if norm is not None:
            mappable = matplotlib.cm.ScalarMappable(norm=norm, cmap=cmap)
        u0, u1, v0, v1 = (1e3 * e for e in view["extent"])
        ax.set_xlim(u0, u1)
        ax.set_ylim(v0, v1)
        ax.set_aspect("equal")
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("z (mm)" if view["plane"] == "xz" else "y (mm)")
        ax.set_title(view["title"], fontsize=9)
    if mappable is not None:
        fig.colorbar(mappable, ax=list(axes[0]), label=views[0]["quantity"], shrink=0.85)
    fig.suptitle(chart["title"], fontsize=10)
    fig.savefig(out_path)
    plt.close(fig)
