// OFF reader (ASCII; spec/errors.md §Import). Keyword prefixes ST (uv), C (colour, ignored),
// N (normal) as in "STCNOFF"; nOFF/4OFF and binary OFF are refused as unsupported. '#' starts
// a comment anywhere (CGAL writes them before the keyword and after values). Each vertex and
// each face is one line: a vertex line holds x y z [nx ny nz] [colour...] [u v], a face line
// n i0 .. i(n-1) [colour...].
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>

#include "vgeo/core/thread_pool.h"
#include "vgeo/mesh/import_text.h"

namespace vgeo::detail {
namespace {

// The shortest vertex line ("0 0 0\n") and face line ("3 0 1 2\n"): bounds on header counts.
constexpr uint64_t kMinVertexLineBytes = 6;
constexpr uint64_t kMinFaceLineBytes = 8;
constexpr size_t kMaxLineTokens = 4096;  // past this a line is not an OFF record we read

struct OffKeyword {
  bool uvs = false, colors = false, normals = false;
};

// Byte classes of the record scan: one table load per byte instead of a chain of compares.
enum : uint8_t { kTokenByte = 0, kBlankByte = 1, kLineEndByte = 2, kCommentByte = 3 };
constexpr std::array<uint8_t, 256> kByteClass = [] {
  std::array<uint8_t, 256> c{};
  for (char b : {' ', '\t', '\r', '\f', '\v'}) c[uint8_t(b)] = kBlankByte;  // TextCursor's blanks
  c[uint8_t('\n')] = kLineEndByte;
  c[uint8_t('#')] = kCommentByte;
  return c;
}();

// Reads the next non-empty line with comments removed into `tokens`; false at the end.
// One pass over the line's bytes (tokens end at a blank, the line's end or a '#', which
// starts a comment to the end of the line): the separate line, comment and token scans cost
// a tenth of a 1M-triangle build.
bool next_record(TextCursor& in, std::vector<std::string_view>& tokens, uint64_t& line) {
  const char* p = in.p;
  const char* const end = in.end;
  auto byte_class = [](const char* q) { return kByteClass[uint8_t(*q)]; };
  while (p < end) {
    line = in.line;
    tokens.clear();
    for (;;) {
      while (p < end && byte_class(p) == kBlankByte) ++p;
      if (p >= end || byte_class(p) == kLineEndByte) break;
      if (byte_class(p) == kCommentByte) {
        while (p < end && byte_class(p) != kLineEndByte) ++p;
        break;
      }
      const char* b = p;
      while (p < end && byte_class(p) == kTokenByte) ++p;
      if (tokens.size() < kMaxLineTokens) tokens.push_back({b, size_t(p - b)});
    }
    if (p < end) {  // past the line break
      ++p;
      ++in.line;
    }
    if (!tokens.empty()) {
      in.p = p;
      return true;
    }
  }
  in.p = p;
  return false;
}

// The fast path: nearly every line of an OFF file is a vertex line of plain numbers or a face
// line of plain indices. Those are read straight from the bytes (no token list) and any other
// line (a comment, a '+' sign, a token a number does not fill, a bad or out-of-range value, a
// blank line) is left untouched for next_record and the checks after it, so values, errors
// and their line numbers are exactly those of the token path. A token read here ends at a
// blank or the line's end, the same bytes next_record's token ends at, so from_chars sees
// the same characters either way.
bool ends_token(const char* q, const char* end) {
  return q >= end || kByteClass[uint8_t(*q)] == kBlankByte || kByteClass[uint8_t(*q)] == kLineEndByte;
}
const char* skip_line_blanks(const char* p, const char* end) {
  while (p < end && kByteClass[uint8_t(*p)] == kBlankByte) ++p;
  return p;
}
// Past the line's end if only blanks are left on it (nullptr otherwise).
const char* past_line_end(const char* p, const char* end, uint64_t& line) {
  p = skip_line_blanks(p, end);
  if (p >= end) return p;
  if (*p != '\n') return nullptr;
  ++line;
  return p + 1;
}

// Moves the cursor past the line that ends at or after p (only blanks may remain on it); false,
// cursor untouched, when something else does.
bool commit_plain_line(TextCursor& in, const char* p) {
  uint64_t line = in.line;
  p = past_line_end(p, in.end, line);
  if (p == nullptr) return false;
  in.p = p;
  in.line = line;
  return true;
}

// A line of exactly `count` numbers into `values`; false (cursor untouched) for any other line.
bool read_plain_number_line(TextCursor& in, float* values, size_t count) {
  const char* p = in.p;
  const char* const end = in.end;
  for (size_t k = 0; k < count; ++k) {
    p = skip_line_blanks(p, end);
    if (p >= end || *p == '+') return false;  // parse_number's sign rules: the token path
    if (const char* q = read_short_decimal(p, end, values[k]); q != nullptr && ends_token(q, end)) {
      p = q;
      continue;
    }
    const auto r = std::from_chars(p, end, values[k]);
    if (r.ec != std::errc() || !ends_token(r.ptr, end)) return false;
    p = r.ptr;
  }
  return commit_plain_line(in, p);
}

// A face line "n i0 .. i(n-1)" of plain indices below `vertex_count` into `ring`; false (cursor
// untouched) for any other line. n stays below next_record's token cap, so a line the token path
// would cut short is left to it.
bool read_plain_face_line(TextCursor& in, int64_t vertex_count, std::vector<uint32_t>& ring) {
  const char* p = in.p;
  const char* const end = in.end;
  // parse_plain_digits fused with the token scan (one pass over the digits); unsigned
  // arithmetic, so a token too long to keep is refused after wrapping, never overflowing.
  auto next_plain_digits = [&](int64_t& value) {
    p = skip_line_blanks(p, end);
    const char* b = p;
    uint64_t v = 0;
    for (unsigned digit; p < end && (digit = unsigned(uint8_t(*p)) - unsigned('0')) <= 9; ++p) v = v * 10 + digit;
    if (p == b || size_t(p - b) > kDigitLoopMaxDigits || !ends_token(p, end)) return false;
    value = int64_t(v);
    return true;
  };
  int64_t n = 0;
  if (!next_plain_digits(n) || uint64_t(n) >= kMaxLineTokens) return false;
  ring.clear();
  for (int64_t c = 0; c < n; ++c) {
    int64_t idx = 0;
    if (!next_plain_digits(idx) || idx >= vertex_count) return false;
    ring.push_back(uint32_t(idx));
  }
  return commit_plain_line(in, p);
}

OffKeyword parse_keyword(std::string_view k, const std::string& where) {
  OffKeyword kw;
  if (k.size() < 3 || k.substr(k.size() - 3) != "OFF")
    fail("MESH_PARSE_ERROR", where, "OFF file does not start with an OFF keyword");
  std::string_view prefix = k.substr(0, k.size() - 3);
  if (prefix.size() >= 2 && prefix.substr(0, 2) == "ST") {
    kw.uvs = true;
    prefix.remove_prefix(2);
  }
  if (!prefix.empty() && prefix[0] == 'C') {
    kw.colors = true;
    prefix.remove_prefix(1);
  }
  if (!prefix.empty() && prefix[0] == 'N') {
    kw.normals = true;
    prefix.remove_prefix(1);
  }
  if (!prefix.empty())
    fail(prefix.find_first_of("n4") != std::string_view::npos ? "MESH_FORMAT_UNSUPPORTED" : "MESH_PARSE_ERROR", where,
         "OFF variant '" + std::string(k.substr(0, 32)) + "' is not supported (nOFF/4OFF/unknown prefix)");
  return kw;
}

float number(std::string_view t, const std::string& where, uint64_t line, const char* what) {
  float v = 0;
  if (!parse_float(t, v))
    fail("MESH_PARSE_ERROR", at_line(where, line), std::string(what) + " '" + std::string(t.substr(0, 32)) + "' is not a number");
  return v;
}

// ---- the body read by line ranges on a pool (ImportOptions::threads > 1) ----
// A body of more than this is read by ranges: ~1.2 ms of parsing per MiB, against the pool's
// start (a thread) and the ranges' line count.
constexpr size_t kParallelBodyBytes = size_t(1) << 20;
// Bytes of the body per task: 256 KiB is ~8,000 lines, ~0.3 ms of parsing against a task's ~1 µs
// hand-out; a 1-3 MB body (armadillo, bunny00) gives 7-11 tasks, where 1 MiB ranges gave 2-3
// (1 + 0.6 MiB on two threads: one range's time, not half the body's), and the 39 MB of the 1M
// sphere ~150.
constexpr size_t kBodyBytesPerTask = size_t(256) << 10;

// The cursor past the empty lines (blanks, a comment) before the first record, which next_record
// skips: the body's ranges then start at the first vertex line (CGAL's files have a blank line
// after the header counts).
TextCursor past_empty_lines(TextCursor in) {
  for (;;) {
    const char* p = skip_line_blanks(in.p, in.end);
    if (p < in.end && kByteClass[uint8_t(*p)] == kCommentByte) {
      const void* nl = std::memchr(p, '\n', size_t(in.end - p));
      p = nl ? static_cast<const char*>(nl) : in.end;
    }
    if (p >= in.end || *p != '\n') return in;
    in.p = p + 1;
    ++in.line;
  }
}

// One byte range of the body, cut after a '\n' so every line lies in one range.
struct BodyRange {
  const char* begin = nullptr;
  const char* end = nullptr;
  uint64_t first_record = 0;  // the body's line index of its first line
  std::vector<uint32_t> indices;  // its faces' triangles, in file order
  size_t repeated_vertex_faces = 0;
  bool plain = true;  // every line it was given was a plain record
};

// Reads the vertex and face records of an OFF file without colours on `pool`, when every body
// line is one plain record (read_plain_number_line / read_plain_face_line: the serial loop's
// fast paths, on the same bytes, so the same values): vertex v is body line v, face f body line
// nv + f, lines past the last face are not read (the serial loop stops there too). Each range
// counts its lines, then parses them by their global index; false (nothing of `mesh` to keep)
// when any line is not plain or the file ends early: the serial loop then reads the whole body
// and reports exactly what it reports today.
bool read_plain_body_in_parallel(const TextCursor& body, int64_t nv, int64_t nf, size_t needed, bool normals,
                                 bool uvs, ThreadPool& pool, Mesh& mesh, size_t& repeated_vertex_faces) {
  std::vector<BodyRange> ranges;
  for (const char* p = body.p; p < body.end;) {
    const char* cut = std::min(body.end, p + kBodyBytesPerTask);
    if (cut < body.end) {
      const void* nl = std::memchr(cut, '\n', size_t(body.end - cut));
      cut = nl ? static_cast<const char*>(nl) + 1 : body.end;
    }
    BodyRange r;
    r.begin = p, r.end = cut;
    ranges.push_back(std::move(r));
    p = cut;
  }
  std::vector<uint64_t> lines(ranges.size());
  pool.parallel_for(ranges.size(), [&](size_t i) {
    lines[i] = uint64_t(std::count(ranges[i].begin, ranges[i].end, '\n'));
  });
  uint64_t first = 0;
  for (size_t i = 0; i < ranges.size(); ++i) ranges[i].first_record = first, first += lines[i];
  // A last line without '\n' is a line too.
  const uint64_t total_lines = first + (body.end > body.p && body.end[-1] != '\n' ? 1 : 0);
  const uint64_t records = uint64_t(nv) + uint64_t(nf);
  if (total_lines < records) return false;
  // Fresh arrays: their pages faulted in on every thread first, so the zero fill runs on
  // mapped pages (on a VM a first touch costs microseconds per page).
  mesh.positions.reserve(size_t(nv) * 3);
  if (normals) mesh.normals.reserve(size_t(nv) * 3);
  if (uvs) mesh.uvs.reserve(size_t(nv) * 2);
  prefault_parallel({{mesh.positions.data(), 4 * mesh.positions.capacity()},
                     {mesh.normals.data(), 4 * mesh.normals.capacity()},
                     {mesh.uvs.data(), 4 * mesh.uvs.capacity()}},
                    pool);
  mesh.positions.resize(size_t(nv) * 3);
  if (normals) mesh.normals.resize(size_t(nv) * 3);
  if (uvs) mesh.uvs.resize(size_t(nv) * 2);
  std::atomic<bool> all_plain{true};
  pool.parallel_for(ranges.size(), [&](size_t i) {
    BodyRange& r = ranges[i];
    if (r.first_record >= records) return;
    TextCursor in(reinterpret_cast<const uint8_t*>(r.begin), size_t(body.end - r.begin));  // the file's end, as serially
    Mesh faces;
    // A triangle per face line of the range (grown past it only by polygons): no regrowth copies.
    const uint64_t range_end = std::min(records, r.first_record + lines[i]);
    if (range_end > uint64_t(nv)) faces.indices.reserve(3 * size_t(range_end - std::max(uint64_t(nv), r.first_record)));
    PolygonSink sink(faces);
    std::vector<uint32_t> ring;
    float values[8];
    for (uint64_t record = r.first_record; in.p < r.end && record < records && all_plain.load(std::memory_order_relaxed);
         ++record) {
      if (record < uint64_t(nv)) {
        if (!read_plain_number_line(in, values, needed)) {
          all_plain.store(false);
          return;
        }
        std::copy(values, values + 3, &mesh.positions[3 * record]);
        if (normals) std::copy(values + 3, values + 6, &mesh.normals[3 * record]);
        if (uvs) std::copy(values + needed - 2, values + needed, &mesh.uvs[2 * record]);
      } else {
        if (!read_plain_face_line(in, nv, ring)) {
          all_plain.store(false);
          return;
        }
        sink.add(ring.data(), ring.size());
      }
    }
    r.indices = std::move(faces.indices);
    r.repeated_vertex_faces = sink.repeated_vertex_faces;
  });
  if (!all_plain.load()) {
    mesh.positions.clear(), mesh.normals.clear(), mesh.uvs.clear();
    return false;
  }
  // The ranges' indices joined in range order, each range copied on the pool to its offset.
  std::vector<size_t> offset(ranges.size() + 1, 0);
  for (size_t i = 0; i < ranges.size(); ++i) {
    offset[i + 1] = offset[i] + ranges[i].indices.size();
    repeated_vertex_faces += ranges[i].repeated_vertex_faces;
  }
  mesh.indices.reserve(offset.back());
  prefault_parallel({{mesh.indices.data(), 4 * mesh.indices.capacity()}}, pool);
  mesh.indices.resize(offset.back());
  pool.parallel_for(ranges.size(), [&](size_t i) {
    std::copy(ranges[i].indices.begin(), ranges[i].indices.end(), mesh.indices.begin() + ptrdiff_t(offset[i]));
    ranges[i].indices = {};
  });
  return true;
}

}  // namespace

void import_off(const uint8_t* data, size_t size, const std::string& where, ImportResult& out, unsigned threads) {
  if (size == 0) fail("MESH_EMPTY", where, "file is empty");
  TextCursor in(data, size);
  std::vector<std::string_view> tok;
  uint64_t line = 0;
  if (!next_record(in, tok, line)) fail("MESH_PARSE_ERROR", where, "OFF file has no OFF keyword");
  const OffKeyword kw = parse_keyword(tok[0], where);
  if (tok.size() > 1 && tok[1] == "BINARY") fail("MESH_FORMAT_UNSUPPORTED", where, "binary OFF is not supported");
  // Counts: on the keyword line or the next record.
  size_t first = 1;
  if (tok.size() < 3) {
    if (!next_record(in, tok, line)) fail("FILE_TRUNCATED", where, "OFF header counts missing");
    first = 0;
  }
  if (tok.size() < first + 2) fail("MESH_PARSE_ERROR", at_line(where, line), "OFF header counts missing");
  int64_t nv = -1, nf = -1;
  if (!parse_int(tok[first], nv) || !parse_int(tok[first + 1], nf))
    fail("MESH_PARSE_ERROR", at_line(where, line), "OFF header counts are not integers");
  if (nv < 0 || nf < 0) fail("MESH_PARSE_ERROR", at_line(where, line), "OFF header counts are negative");
  if (uint64_t(nv) > in.remaining() / kMinVertexLineBytes || uint64_t(nf) > in.remaining() / kMinFaceLineBytes + 1)
    fail("FILE_TRUNCATED", where, "OFF header declares " + std::to_string(nv) + " vertices and " + std::to_string(nf) +
                                      " faces, more than a " + std::to_string(size) + "-byte file can hold");
  Mesh mesh;
  const size_t needed = 3 + (kw.normals ? 3 : 0) + (kw.uvs ? 2 : 0);
  if (threads != 1 && !kw.colors && in.remaining() > kParallelBodyBytes) {
    ThreadPool pool(threads);
    PolygonSink sink(mesh);  // its count: the sum of the ranges' (the serial sink counts the same faces)
    if (pool.size() > 1 && read_plain_body_in_parallel(past_empty_lines(in), nv, nf, needed, kw.normals, kw.uvs, pool,
                                                       mesh, sink.repeated_vertex_faces)) {
      sink.finish(out);
      push_single_mesh_scene(std::move(mesh), where, out);
      return;
    }
  }
  mesh.positions.reserve(size_t(nv) * 3);
  if (kw.normals) mesh.normals.reserve(size_t(nv) * 3);
  if (kw.uvs) mesh.uvs.reserve(size_t(nv) * 2);
  float values[8];  // x y z [nx ny nz] [u v]: `needed` at most
  for (int64_t v = 0; v < nv; ++v) {
    if (!kw.colors && read_plain_number_line(in, values, needed)) {
      // push_back per value: a ranged insert of 2 or 3 values is a memmove call each.
      for (size_t k = 0; k < 3; ++k) mesh.positions.push_back(values[k]);
      if (kw.normals)
        for (size_t k = 3; k < 6; ++k) mesh.normals.push_back(values[k]);
      if (kw.uvs)
        for (size_t k = needed - 2; k < needed; ++k) mesh.uvs.push_back(values[k]);
      continue;
    }
    if (!next_record(in, tok, line))
      fail("FILE_TRUNCATED", where, "OFF file ends after " + std::to_string(v) + " of " + std::to_string(nv) + " vertices");
    if (tok.size() < needed || (!kw.colors && tok.size() != needed))
      fail("MESH_PARSE_ERROR", at_line(where, line),
           "OFF vertex line has " + std::to_string(tok.size()) + " values, expected " + std::to_string(needed) +
               (kw.colors ? " or more" : ""));
    for (size_t k = 0; k < 3; ++k) mesh.positions.push_back(number(tok[k], where, line, "coordinate"));
    if (kw.normals)
      for (size_t k = 3; k < 6; ++k) mesh.normals.push_back(number(tok[k], where, line, "normal"));
    if (kw.uvs)
      for (size_t k = tok.size() - 2; k < tok.size(); ++k) mesh.uvs.push_back(number(tok[k], where, line, "uv"));
  }
  // Room for one triangle per face (the common case; the header bound above caps it at 1.5× the
  // file's size): growing by doubling touched twice the final array and copied it on the way.
  mesh.indices.reserve(3 * size_t(nf));
  PolygonSink sink(mesh);
  std::vector<uint32_t> ring;
  for (int64_t f = 0; f < nf; ++f) {
    if (read_plain_face_line(in, nv, ring)) {
      sink.add(ring.data(), ring.size());
      continue;
    }
    if (!next_record(in, tok, line))
      fail("FILE_TRUNCATED", where, "OFF file ends after " + std::to_string(f) + " of " + std::to_string(nf) + " faces");
    int64_t n = -1;
    if (!parse_int(tok[0], n) || n < 0)
      fail("MESH_PARSE_ERROR", at_line(where, line), "OFF face corner count '" + std::string(tok[0].substr(0, 32)) + "' is invalid");
    if (uint64_t(n) + 1 > tok.size())
      fail("MESH_PARSE_ERROR", at_line(where, line),
           "OFF face declares " + std::to_string(n) + " corners but its line holds " + std::to_string(tok.size() - 1) + " values");
    ring.clear();
    for (int64_t c = 1; c <= n; ++c) {
      int64_t idx = -1;
      if (!parse_int(tok[size_t(c)], idx))
        fail("MESH_PARSE_ERROR", at_line(where, line), "OFF face index '" + std::string(tok[size_t(c)].substr(0, 32)) + "' is not an integer");
      if (idx < 0 || idx >= nv)
        fail("INDEX_OUT_OF_RANGE", at_line(where, line),
             "OFF face refers to vertex " + std::to_string(idx) + " of " + std::to_string(nv));
      ring.push_back(uint32_t(idx));
    }
    sink.add(ring.data(), ring.size());
  }
  sink.finish(out);
  push_single_mesh_scene(std::move(mesh), where, out);
}

}  // namespace vgeo::detail
