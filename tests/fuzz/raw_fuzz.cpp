// Fuzz target: headerless raw volumes (io/metaimage.cpp read_raw), byte level. The first bytes
// choose the layout the command line would give (dims, type, byte order, header size); the rest is
// the file.
#include "fuzz_support.hpp"
#include "graintwin/io/metaimage.hpp"

GRAINTWIN_FUZZ_TARGET(raw) {
  graintwin::fuzz::ByteReader in(data, size);
  graintwin::io::RawLayout layout;
  // Small dims mostly (a size that matches the file), huge ones sometimes (overflowing products).
  for (auto& d : layout.shape) {
    const std::uint8_t mode = in.u8();
    d = mode < 200 ? mode % 9 : in.u64();
  }
  const std::uint8_t flags = in.u8();
  layout.dtype = static_cast<graintwin::DType>(flags % 4);
  layout.big_endian = flags & 4;
  layout.header_bytes = (flags & 8) ? in.u64() : in.u8() % 16;
  const auto path = graintwin::fuzz::write_scratch("input.raw", in.rest(), in.rest_size());
  graintwin::fuzz::expect_clean("read_raw", [&] { graintwin::fuzz::check_volume("read_raw", graintwin::io::read_raw(path, layout)); });
}
