#include "zstd_payload.h"

#include <zstd.h>

#include <algorithm>
#include <memory>

namespace dysa::codec {
namespace {

struct ZstdCCtxDeleter {
  void operator()(ZSTD_CCtx* c) const { ZSTD_freeCCtx(c); }
};
struct ZstdDCtxDeleter {
  void operator()(ZSTD_DCtx* c) const { ZSTD_freeDCtx(c); }
};

}  // namespace

std::string Compress(std::span<const uint8_t> raw, int level, std::vector<uint8_t>& out,
                     size_t& size) {
  thread_local std::unique_ptr<ZSTD_CCtx, ZstdCCtxDeleter> cctx(ZSTD_createCCtx());
  out.resize(std::max(out.size(), ZSTD_compressBound(raw.size())));
  size = ZSTD_compressCCtx(cctx.get(), out.data(), out.size(), raw.data(), raw.size(), level);
  if (ZSTD_isError(size)) return std::string("zstd: ") + ZSTD_getErrorName(size);
  return {};
}

std::string Decompress(std::span<const uint8_t> payload, uint32_t raw_size, uint64_t max_raw_size,
                       std::vector<uint8_t>& raw) {
  const unsigned long long content = ZSTD_getFrameContentSize(payload.data(), payload.size());
  if (content != raw_size) return "payload size does not match the header";
  if (raw_size > max_raw_size) return "raw size too large";
  thread_local std::unique_ptr<ZSTD_DCtx, ZstdDCtxDeleter> dctx(ZSTD_createDCtx());
  raw.resize(raw_size);
  const size_t got =
      ZSTD_decompressDCtx(dctx.get(), raw.data(), raw.size(), payload.data(), payload.size());
  if (ZSTD_isError(got) || got != raw.size()) return "payload does not decompress";
  return {};
}

}  // namespace dysa::codec
