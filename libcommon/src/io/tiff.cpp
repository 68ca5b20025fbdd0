#include "graintwin/io/tiff.hpp"

#include <fmt/format.h>
#include <tiffio.h>

#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <memory>
#include <optional>
#include <sstream>

#include "graintwin/core/error.hpp"
#include "graintwin/core/strings.hpp"

namespace graintwin::io {

namespace {

thread_local std::string tiff_last_error;

void tiff_error_handler(const char* module, const char* fmt, va_list ap) {
  char buf[512];
  std::vsnprintf(buf, sizeof buf, fmt, ap);
  tiff_last_error = buf;
}

struct TiffHandlers {
  TiffHandlers() {
    TIFFSetErrorHandler(tiff_error_handler);
    TIFFSetWarningHandler(nullptr);  // unknown private tags are common and harmless
  }
} tiff_handlers;

struct TiffCloser {
  void operator()(TIFF* t) const { TIFFClose(t); }
};
using TiffPtr = std::unique_ptr<TIFF, TiffCloser>;

std::string libtiff_says() {
  std::string s = tiff_last_error.empty() ? "" : " (libtiff: " + tiff_last_error + ")";
  tiff_last_error.clear();
  return s;
}

struct PageFormat {
  std::uint32_t width = 0, height = 0;
  DType dtype = DType::uint8;
};

PageFormat page_format(TIFF* t, const std::filesystem::path& path, int page) {
  PageFormat f;
  std::uint16_t spp = 1, bps = 8, fmt = SAMPLEFORMAT_UINT;
  TIFFGetField(t, TIFFTAG_IMAGEWIDTH, &f.width);
  TIFFGetField(t, TIFFTAG_IMAGELENGTH, &f.height);
  TIFFGetFieldDefaulted(t, TIFFTAG_SAMPLESPERPIXEL, &spp);
  TIFFGetFieldDefaulted(t, TIFFTAG_BITSPERSAMPLE, &bps);
  TIFFGetFieldDefaulted(t, TIFFTAG_SAMPLEFORMAT, &fmt);
  const std::string where = path.string() + " page " + std::to_string(page);
  if (spp != 1)
    throw DataError(where + " has " + std::to_string(spp) +
                    " samples per pixel (a colour image); save the slices as single-channel grey images");
  if (fmt == SAMPLEFORMAT_UINT && bps == 8) f.dtype = DType::uint8;
  else if (fmt == SAMPLEFORMAT_UINT && bps == 16) f.dtype = DType::uint16;
  else if (fmt == SAMPLEFORMAT_UINT && bps == 32) f.dtype = DType::uint32;
  else if (fmt == SAMPLEFORMAT_IEEEFP && bps == 32) f.dtype = DType::float32;
  else
    throw DataError(where + " has " + std::to_string(bps) + "-bit " +
                    (fmt == SAMPLEFORMAT_INT ? "signed" : fmt == SAMPLEFORMAT_IEEEFP ? "float" : "unsigned") +
                    " samples; GrainTwin reads uint8, uint16, uint32 and float32 TIFFs");
  if (f.width == 0 || f.height == 0) throw DataError(where + " is empty (0 pixels)");
  return f;
}

// Reads the current directory into `dst` (height x width elements of `bytes` each).
void read_page(TIFF* t, const PageFormat& f, std::size_t bytes, unsigned char* dst,
               const std::filesystem::path& path, int page) {
  const std::string where = path.string() + " page " + std::to_string(page);
  if (TIFFIsTiled(t)) {
    std::uint32_t tw = 0, th = 0;
    TIFFGetField(t, TIFFTAG_TILEWIDTH, &tw);
    TIFFGetField(t, TIFFTAG_TILELENGTH, &th);
    std::vector<unsigned char> tile(TIFFTileSize(t));
    for (std::uint32_t y0 = 0; y0 < f.height; y0 += th)
      for (std::uint32_t x0 = 0; x0 < f.width; x0 += tw) {
        if (TIFFReadTile(t, tile.data(), x0, y0, 0, 0) < 0)
          throw DataError(where + " is truncated or damaged" + libtiff_says());
        for (std::uint32_t y = y0; y < std::min(y0 + th, f.height); ++y) {
          const std::uint32_t w = std::min(tw, f.width - x0);
          std::memcpy(dst + (static_cast<std::size_t>(y) * f.width + x0) * bytes,
                      tile.data() + static_cast<std::size_t>(y - y0) * tw * bytes, w * bytes);
        }
      }
  } else {
    for (std::uint32_t y = 0; y < f.height; ++y)
      if (TIFFReadScanline(t, dst + static_cast<std::size_t>(y) * f.width * bytes, y, 0) < 0)
        throw DataError(where + " is truncated or damaged" + libtiff_says());
  }
}

// Our writer stores exact geometry in the ImageJ-style description; read it back.
void parse_description(const std::string& desc, std::optional<Vec3>& voxel, std::optional<Vec3>& origin,
                       std::optional<double>& imagej_spacing, double& imagej_unit_m) {
  std::istringstream in(desc);
  std::string line;
  while (std::getline(in, line)) {
    const auto eq = line.find('=');
    if (eq == std::string::npos) continue;
    const std::string key = trim(line.substr(0, eq)), val = trim(line.substr(eq + 1));
    auto triple = [&]() -> std::optional<Vec3> {
      const auto p = split(val, ',');
      if (p.size() != 3) return std::nullopt;
      try {
        return Vec3{std::stod(p[0]), std::stod(p[1]), std::stod(p[2])};
      } catch (...) {
        return std::nullopt;
      }
    };
    if (key == "graintwin_voxel_size_m") voxel = triple();
    else if (key == "graintwin_origin_m") origin = triple();
    else if (key == "spacing") {
      try { imagej_spacing = std::stod(val); } catch (...) {}
    } else if (key == "unit") {
      if (const std::optional<double> unit_m = length_unit_m(lower(val))) imagej_unit_m = *unit_m;
    }
  }
}

// The volume is allocated from page 0's header before any pixel is read, so the header must not
// declare more than the file can hold: uncompressed pages at most the file's bytes, compressed ones
// at most 20000 times them (lossless codecs stay far below that on scan data; deflate cannot pass
// ~1032:1). A damaged 1 KB file declaring 65535 x 65535 float pages is refused, not zero-filled.
void check_declared_size(TIFF* t, const PageFormat& first, int pages, const std::filesystem::path& path) {
  bool compressed = false;
  for (int p = 0; p < pages && !compressed; ++p) {
    if (!TIFFSetDirectory(t, static_cast<tdir_t>(p))) break;  // read_pages reports it
    std::uint16_t c = COMPRESSION_NONE;
    TIFFGetFieldDefaulted(t, TIFFTAG_COMPRESSION, &c);
    compressed = c != COMPRESSION_NONE;
  }
  TIFFSetDirectory(t, 0);
  std::error_code ec;
  const double file_bytes = static_cast<double>(std::filesystem::file_size(path, ec));
  const double declared = static_cast<double>(pages) * first.height * first.width * dtype_bytes(first.dtype);
  if (!ec && declared > (compressed ? 20000.0 : 1.0) * file_bytes)
    throw DataError(fmt::format("{} declares {} pages of {} x {} {} pixels ({:.3g} bytes), more than its {:g} bytes can hold; "
                                "the file is truncated or damaged",
                                path.string(), pages, first.width, first.height, dtype_name(first.dtype), declared, file_bytes));
}

template <class T>
Volume<T> read_pages(TIFF* t, const PageFormat& first, int pages, const std::filesystem::path& path) {
  Volume<T> v({static_cast<std::size_t>(pages), first.height, first.width});
  for (int p = 0; p < pages; ++p) {
    if (!TIFFSetDirectory(t, static_cast<tdir_t>(p)))
      throw DataError(path.string() + ": cannot reach page " + std::to_string(p) + libtiff_says());
    const PageFormat f = page_format(t, path, p);
    if (f.width != first.width || f.height != first.height || f.dtype != first.dtype)
      throw DataError(path.string() + " page " + std::to_string(p) + " is " + std::to_string(f.width) + " x " +
                      std::to_string(f.height) + " " + dtype_name(f.dtype) + " but page 0 is " +
                      std::to_string(first.width) + " x " + std::to_string(first.height) + " " +
                      dtype_name(first.dtype) + "; all slices of a volume must match");
    read_page(t, f, sizeof(T), reinterpret_cast<unsigned char*>(&v(p, 0, 0)), path, p);
  }
  return v;
}

}  // namespace

AnyVolume read_tiff(const std::filesystem::path& path) {
  TiffPtr t(TIFFOpen(path.c_str(), "rm"));  // m: no memory mapping, so truncation is an error, not SIGBUS
  if (!t) throw DataError(path.string() + " is not a readable TIFF file" + libtiff_says());
  tiff_last_error.clear();
  const int pages = TIFFNumberOfDirectories(t.get());
  if (pages <= 0) throw DataError(path.string() + " holds no image");
  // libtiff stops counting at a directory it cannot read: a truncated stack would lose slices silently.
  if (!tiff_last_error.empty())
    throw DataError(path.string() + " is truncated or damaged after page " + std::to_string(pages - 1) +
                    libtiff_says() + "; re-export the stack");
  const PageFormat first = page_format(t.get(), path, 0);
  check_declared_size(t.get(), first, pages, path);

  std::optional<Vec3> voxel, origin;
  std::optional<double> spacing;
  double unit_m = 0.0;
  char* desc = nullptr;
  if (TIFFGetField(t.get(), TIFFTAG_IMAGEDESCRIPTION, &desc) && desc)
    parse_description(desc, voxel, origin, spacing, unit_m);
  float xres = 0.f, yres = 0.f;
  std::uint16_t resunit = RESUNIT_NONE;
  const bool has_res = TIFFGetField(t.get(), TIFFTAG_XRESOLUTION, &xres) &&
                       TIFFGetField(t.get(), TIFFTAG_YRESOLUTION, &yres) && xres > 0 && yres > 0;
  TIFFGetFieldDefaulted(t.get(), TIFFTAG_RESOLUTIONUNIT, &resunit);

  AnyVolume out;
  switch (first.dtype) {
    case DType::uint8: out = read_pages<std::uint8_t>(t.get(), first, pages, path); break;
    case DType::uint16: out = read_pages<std::uint16_t>(t.get(), first, pages, path); break;
    case DType::uint32: out = read_pages<std::uint32_t>(t.get(), first, pages, path); break;
    case DType::float32: out = read_pages<float>(t.get(), first, pages, path); break;
  }
  // Geometry: our exact keys first, then ImageJ's calibration, then TIFF resolution tags. Where none
  // is present voxel_size stays 0 and the caller must supply it.
  Vec3 vs{0.0, 0.0, 0.0};
  if (voxel) {
    vs = *voxel;
  } else if (unit_m > 0.0 && has_res) {
    vs = {spacing.value_or(1.0 / xres) * unit_m, unit_m / yres, unit_m / xres};
  } else if (has_res && (resunit == RESUNIT_CENTIMETER || resunit == RESUNIT_INCH)) {
    const double u = resunit == RESUNIT_CENTIMETER ? 0.01 : 0.0254;
    vs = {u / xres, u / yres, u / xres};
  }
  std::visit(
      [&](auto& vol) {
        vol.set_voxel_size(vs);
        if (origin) vol.set_origin(*origin);
      },
      out);
  return out;
}

namespace {
template <class T>
void write_pages(TIFF* t, const Volume<T>& v, const std::filesystem::path& path) {
  const Vec3& vs = v.voxel_size();
  const Vec3& o = v.origin();
  char desc[512];
  std::snprintf(desc, sizeof desc,
                "ImageJ=1.53t\nimages=%zu\nslices=%zu\nunit=micron\nspacing=%.17g\nloop=false\n"
                "graintwin_voxel_size_m=%.17g,%.17g,%.17g\ngraintwin_origin_m=%.17g,%.17g,%.17g\n",
                v.nz(), v.nz(), vs[0] * 1e6, vs[0], vs[1], vs[2], o[0], o[1], o[2]);
  const std::uint16_t fmt = std::is_floating_point_v<T> ? SAMPLEFORMAT_IEEEFP : SAMPLEFORMAT_UINT;
  for (std::size_t z = 0; z < v.nz(); ++z) {
    TIFFSetField(t, TIFFTAG_IMAGEWIDTH, static_cast<std::uint32_t>(v.nx()));
    TIFFSetField(t, TIFFTAG_IMAGELENGTH, static_cast<std::uint32_t>(v.ny()));
    TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, static_cast<std::uint16_t>(8 * sizeof(T)));
    TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, static_cast<std::uint16_t>(1));
    TIFFSetField(t, TIFFTAG_SAMPLEFORMAT, fmt);
    TIFFSetField(t, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_MINISBLACK);
    TIFFSetField(t, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
    TIFFSetField(t, TIFFTAG_COMPRESSION, COMPRESSION_NONE);
    TIFFSetField(t, TIFFTAG_ROWSPERSTRIP, TIFFDefaultStripSize(t, 0));
    TIFFSetField(t, TIFFTAG_SUBFILETYPE, FILETYPE_PAGE);
    TIFFSetField(t, TIFFTAG_PAGENUMBER, static_cast<std::uint16_t>(z), static_cast<std::uint16_t>(v.nz()));
    if (vs[2] > 0 && vs[1] > 0) {
      TIFFSetField(t, TIFFTAG_XRESOLUTION, static_cast<float>(1e-6 / vs[2]));  // pixels per micron
      TIFFSetField(t, TIFFTAG_YRESOLUTION, static_cast<float>(1e-6 / vs[1]));
      TIFFSetField(t, TIFFTAG_RESOLUTIONUNIT, RESUNIT_NONE);
    }
    if (z == 0) TIFFSetField(t, TIFFTAG_IMAGEDESCRIPTION, desc);
    for (std::size_t y = 0; y < v.ny(); ++y)
      if (TIFFWriteScanline(t, const_cast<T*>(&v(z, y, 0)), static_cast<std::uint32_t>(y), 0) < 0)
        throw DataError(path.string() + ": cannot write slice " + std::to_string(z) + libtiff_says() + "; is the disk full?");
    if (!TIFFWriteDirectory(t))
      throw DataError(path.string() + ": cannot write slice " + std::to_string(z) + libtiff_says());
  }
}
}  // namespace

void write_tiff(const std::filesystem::path& path, const AnyVolume& v) {
  const Shape3 s = shape_of_any(v);
  const double bytes = static_cast<double>(s[0]) * s[1] * s[2] * dtype_bytes(dtype_of_any(v));
  const bool big = bytes > 3.5 * 1024.0 * 1024.0 * 1024.0;
  TiffPtr t(TIFFOpen(path.c_str(), big ? "w8" : "w"));
  if (!t) throw DataError(path.string() + ": cannot create TIFF file" + libtiff_says());
  std::visit([&](const auto& vol) { write_pages(t.get(), vol, path); }, v);
}

}  // namespace graintwin::io
