// xplane_proto: the bytes of X-Plane 11/12's UDP messages (docs/xplane-protocol.md):
// little-endian packing, DATA and RREF-reply encoders, request framing checks.
// No sockets and no simulation here.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace xp
{

constexpr float kNoData = -999.0f; // bytes 00 c0 79 c4
constexpr size_t kHeader = 5;      // 4 letters + 1 byte
constexpr size_t kDataRecord = 36; // int32 row + 8 float32
constexpr size_t kDrefSize = 509;  // '<4sBf500s'
constexpr size_t kDrefPath = 500;
constexpr size_t kRrefReqSize = 413; // '<4sBii400s'
constexpr size_t kRrefPath = 400;
constexpr size_t kIse4Size = 37; // '<4sxi16s8si'
constexpr int kRrefMaxRecords = 183;
constexpr uint8_t kDataOutByte4 = '*'; // X-Plane 11 and 12
constexpr uint8_t kRrefOutByte4 = ','; // X-Plane 11 and 12

using Bytes = std::vector<uint8_t>;

struct DataRow {
	int32_t index;
	float col[8];
};

void put_i32(Bytes &b, int32_t v);
void put_f32(Bytes &b, float v);
// The same little-endian packing into p[0..3].
void store_i32(uint8_t *p, int32_t v);
void store_f32(uint8_t *p, float v);
int32_t get_i32(const uint8_t *p);
float get_f32(const uint8_t *p);

// DATA output: "DATA" + byte4 + one record per row, in the order given.
Bytes encode_data(const std::vector<DataRow> &rows, uint8_t byte4 = kDataOutByte4);
// The same from n rows at rows, into out (resized to the datagram's length).
void encode_data(const DataRow *rows, size_t n, Bytes &out, uint8_t byte4 = kDataOutByte4);
// RREF replies: "RREF" + ',' + (index, value) records, at most 183 per datagram.
std::vector<Bytes> encode_rref_replies(const std::vector<std::pair<int32_t, float>> &recs,
				       uint8_t byte4 = kRrefOutByte4);

enum class Msg { Data, Dref, Rref, Dsel, Usel, Cmnd, Ise4, Unknown };
// Matches bytes 0-3 only (byte 4 is skipped whatever it holds). len >= 5 required.
Msg message_type(const uint8_t *p, size_t len);

// A NUL-terminated path inside a fixed field of n bytes: false when there is no
// NUL in the field, the path is empty or holds bytes outside printable ASCII.
bool field_path(const uint8_t *field, size_t n, std::string &out);
// The same, the path as a view into field (no copy).
bool field_path(const uint8_t *field, size_t n, std::string_view &out);

// "sim/x/name[3]" -> base "sim/x/name", index 3; no brackets -> index -1.
// False for a malformed subscript.
bool split_index(const std::string &path, std::string &base, int &index);
// The same, base as a view into path (no copy).
bool split_index(std::string_view path, std::string_view &base, int &index);

} // namespace xp
