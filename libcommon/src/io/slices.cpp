#include "graintwin/io/slices.hpp"

#include <glob.h>
#include <png.h>
#include <sys/stat.h>

#include <algorithm>
#include <csetjmp>
#include <cstdio>
#include <cstring>

#include "graintwin/core/error.hpp"
#include "graintwin/core/strings.hpp"
#include "graintwin/io/tiff.hpp"

namespace graintwin::io {

namespace fs = std::filesystem;

namespace {
bool is_slice_file(const fs::path& p) {
  const std::string ext = lower(p.extension().string());
  return ext == ".tif" || ext == ".tiff" || ext == ".png";
}
bool is_png(const fs::path& p) { return lower(p.extension().string()) == ".png"; }
}  // namespace

std::vector<fs::path> list_slices(const std::string& folder_or_glob) {
  std::vector<fs::path> files;
  std::error_code ec;
  if (fs::is_directory(folder_or_glob, ec)) {
    for (const auto& e : fs::directory_iterator(folder_or_glob, ec))
      if (e.is_regular_file() && is_slice_file(e.path())) files.push_back(e.path());
    if (files.empty())
      throw UsageError("folder " + folder_or_glob + " holds no .tif, .tiff or .png slices; point to the slice folder");
  } else {
    glob_t g{};
    const int rc = ::glob(folder_or_glob.c_str(), 0, nullptr, &g);
    if (rc == 0)
      for (std::size_t i = 0; i < g.gl_pathc; ++i)
        if (fs::is_regular_file(g.gl_pathv[i], ec)) files.emplace_back(g.gl_pathv[i]);
    globfree(&g);
    if (files.empty()) throw UsageError("no file matches " + folder_or_glob + "; check the path or pattern");
  }
  std::sort(files.begin(), files.end(),
            [](const fs::path& a, const fs::path& b) { return natural_less(a.filename().string(), b.filename().string()); });
  return files;
}

namespace {

struct PngRaw {
  std::uint32_t width = 0, height = 0;
  int bit_depth = 0;
  int color_type = 0;
  std::vector<unsigned char> pixels;  // rows, native-endian samples
  char error[256] = {0};
};

void png_error_to_buffer(png_structp png, png_const_charp msg) {
  auto* raw = static_cast<PngRaw*>(png_get_error_ptr(png));
  std::snprintf(raw->error, sizeof raw->error, "%s", msg);
  png_longjmp(png, 1);
}
void png_warning_ignored(png_structp, png_const_charp) {}

// C-style on purpose: libpng reports errors by longjmp, so no C++ object lives in this frame.
bool png_read_raw(const char* path, PngRaw* raw) {
  FILE* fp = std::fopen(path, "rb");
  if (!fp) {
    std::snprintf(raw->error, sizeof raw->error, "cannot open file");
    return false;
  }
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, raw, png_error_to_buffer, png_warning_ignored);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) {
    std::fclose(fp);
    return false;
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    std::fclose(fp);
    return false;
  }
  png_init_io(png, fp);
  png_read_info(png, info);
  raw->width = png_get_image_width(png, info);
  raw->height = png_get_image_height(png, info);
  raw->bit_depth = png_get_bit_depth(png, info);
  raw->color_type = png_get_color_type(png, info);
  if (raw->color_type != PNG_COLOR_TYPE_GRAY) {
    png_destroy_read_struct(&png, &info, nullptr);
    std::fclose(fp);
    return true;  // the caller reports the colour type
  }
  if (raw->bit_depth < 8) {
    png_set_expand_gray_1_2_4_to_8(png);
    raw->bit_depth = 8;
  }
  if (raw->bit_depth == 16) png_set_swap(png);  // PNG is big-endian
  png_read_update_info(png, info);
  const std::size_t row = png_get_rowbytes(png, info);
  // The pixels come from zlib streams in the file, which expand at most ~1032:1: a header
  // declaring more (libpng allows 10^6 x 10^6) is damage, and must not size an allocation.
  struct stat st;
  const double file_bytes = ::fstat(::fileno(fp), &st) == 0 ? static_cast<double>(st.st_size) : 0.0;
  if (static_cast<double>(row) * raw->height > 1100.0 * file_bytes + 1e6) {
    std::snprintf(raw->error, sizeof raw->error, "its header declares %u x %u pixels, far more than its %.0f bytes can hold",
                  raw->width, raw->height, file_bytes);
    png_destroy_read_struct(&png, &info, nullptr);
    std::fclose(fp);
    return false;
  }
  raw->pixels.resize(row * raw->height);
  for (std::uint32_t y = 0; y < raw->height; ++y) png_read_row(png, raw->pixels.data() + y * row, nullptr);
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  std::fclose(fp);
  return true;
}

}  // namespace

AnyVolume read_png(const fs::path& path) {
  PngRaw raw;
  if (!png_read_raw(path.c_str(), &raw))
    throw DataError(path.string() + " is not a readable PNG file (" + raw.error + ")");
  if (raw.color_type != PNG_COLOR_TYPE_GRAY)
    throw DataError(path.string() + " is a colour or palette PNG; save the slices as single-channel grey images");
  if (raw.bit_depth == 16) {
    Volume<std::uint16_t> v({1, raw.height, raw.width}, {0.0, 0.0, 0.0});
    std::memcpy(v.data(), raw.pixels.data(), v.size() * 2);
    return v;
  }
  Volume<std::uint8_t> v({1, raw.height, raw.width}, {0.0, 0.0, 0.0});
  std::memcpy(v.data(), raw.pixels.data(), v.size());
  return v;
}

namespace {
/// channels: 1 (grey) or 3 (RGB), 8 or 16 bits each.
bool png_write_raw(const char* path, std::uint32_t w, std::uint32_t h, int depth, int channels, const unsigned char* data) {
  FILE* fp = std::fopen(path, "wb");
  if (!fp) return false;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info || setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    std::fclose(fp);
    return false;
  }
  png_init_io(png, fp);
  png_set_IHDR(png, info, w, h, depth, channels == 3 ? PNG_COLOR_TYPE_RGB : PNG_COLOR_TYPE_GRAY, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  if (depth == 16) png_set_swap(png);
  const std::size_t row = static_cast<std::size_t>(w) * static_cast<std::size_t>(channels * depth / 8);
  for (std::uint32_t y = 0; y < h; ++y) png_write_row(png, data + y * row);
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return std::fclose(fp) == 0;
}
}  // namespace

void write_png(const fs::path& path, const AnyVolume& slice) {
  const Shape3 s = shape_of_any(slice);
  if (s[0] != 1) throw DataError("write_png: expected one slice, got " + std::to_string(s[0]));
  bool ok = false;
  if (const auto* v8 = std::get_if<Volume<std::uint8_t>>(&slice))
    ok = png_write_raw(path.c_str(), s[2], s[1], 8, 1, v8->data());
  else if (const auto* v16 = std::get_if<Volume<std::uint16_t>>(&slice))
    ok = png_write_raw(path.c_str(), s[2], s[1], 16, 1, reinterpret_cast<const unsigned char*>(v16->data()));
  else
    throw DataError(path.string() + ": PNG slices must be uint8 or uint16; cast the volume first");
  if (!ok) throw DataError(path.string() + ": cannot write PNG; check that the folder is writable");
}

void write_png_rgb(const fs::path& path, std::size_t width, std::size_t height, const std::vector<std::uint8_t>& rgb) {
  if (rgb.size() != 3 * width * height)
    throw DataError("write_png_rgb: " + std::to_string(rgb.size()) + " bytes do not make a " + std::to_string(width) +
                    " x " + std::to_string(height) + " RGB image");
  if (!png_write_raw(path.c_str(), static_cast<std::uint32_t>(width), static_cast<std::uint32_t>(height), 8, 3, rgb.data()))
    throw DataError(path.string() + ": cannot write PNG; check that the folder is writable");
}

namespace {
template <class T>
void append_slice(Volume<T>& v, std::size_t z, const AnyVolume& s) {
  const auto& src = std::get<Volume<T>>(s);
  std::copy(src.values().begin(), src.values().end(), &v(z, 0, 0));
}
}  // namespace

AnyVolume read_slices(const std::vector<fs::path>& files) {
  if (files.empty()) throw UsageError("no slice files given");
  auto read_one = [](const fs::path& f) {
    AnyVolume s = is_png(f) ? read_png(f) : read_tiff(f);
    if (shape_of_any(s)[0] != 1)
      throw DataError(f.string() + " has " + std::to_string(shape_of_any(s)[0]) +
                      " pages; a slice series needs one 2-D image per file");
    return s;
  };
  const AnyVolume first = read_one(files[0]);
  const Shape3 s0 = shape_of_any(first);
  const DType t0 = dtype_of_any(first);
  AnyVolume out = std::visit(
      [&](const auto& f) -> AnyVolume {
        using T = typename std::decay_t<decltype(f)>::value_type;
        Volume<T> v({files.size(), s0[1], s0[2]}, f.voxel_size(), f.origin());
        return v;
      },
      first);
  for (std::size_t z = 0; z < files.size(); ++z) {
    const AnyVolume s = z == 0 ? first : read_one(files[z]);
    const Shape3 sz = shape_of_any(s);
    if (sz[1] != s0[1] || sz[2] != s0[2] || dtype_of_any(s) != t0)
      throw DataError(files[z].string() + " is " + std::to_string(sz[2]) + " x " + std::to_string(sz[1]) + " " +
                      dtype_name(dtype_of_any(s)) + " but " + files[0].string() + " is " + std::to_string(s0[2]) +
                      " x " + std::to_string(s0[1]) + " " + dtype_name(t0) + "; all slices must match");
    std::visit([&](auto& v) { append_slice(v, z, s); }, out);
  }
  // A 2-D slice knows at most its in-plane pixel size; z spacing must come from the user.
  std::visit([](auto& v) {
    Vec3 vs = v.voxel_size();
    vs[0] = 0.0;
    if (vs[1] <= 0.0 || vs[2] <= 0.0) vs = {0.0, 0.0, 0.0};
    v.set_voxel_size(vs);
  }, out);
  return out;
}

}  // namespace graintwin::io
