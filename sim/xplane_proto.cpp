// xplane_proto: byte-level encoding and framing checks.
#include "xplane_proto.hpp"

#include <cstring>

namespace xp
{

void store_i32(uint8_t *p, int32_t v)
{
	uint32_t u;
	std::memcpy(&u, &v, 4);
	// four stores the compiler merges into one on a little-endian host
	p[0] = static_cast<uint8_t>(u);
	p[1] = static_cast<uint8_t>(u >> 8);
	p[2] = static_cast<uint8_t>(u >> 16);
	p[3] = static_cast<uint8_t>(u >> 24);
}

void store_f32(uint8_t *p, float v)
{
	int32_t i;
	std::memcpy(&i, &v, 4);
	store_i32(p, i);
}

void put_i32(Bytes &b, int32_t v)
{
	const size_t o = b.size();
	b.resize(o + 4);
	store_i32(b.data() + o, v);
}

void put_f32(Bytes &b, float v)
{
	const size_t o = b.size();
	b.resize(o + 4);
	store_f32(b.data() + o, v);
}

int32_t get_i32(const uint8_t *p)
{
	uint32_t u = static_cast<uint32_t>(p[0]) | (static_cast<uint32_t>(p[1]) << 8) |
		     (static_cast<uint32_t>(p[2]) << 16) | (static_cast<uint32_t>(p[3]) << 24);
	int32_t v;
	std::memcpy(&v, &u, 4);
	return v;
}

float get_f32(const uint8_t *p)
{
	uint32_t u = static_cast<uint32_t>(p[0]) | (static_cast<uint32_t>(p[1]) << 8) |
		     (static_cast<uint32_t>(p[2]) << 16) | (static_cast<uint32_t>(p[3]) << 24);
	float v;
	std::memcpy(&v, &u, 4);
	return v;
}

static void put_tag(Bytes &b, const char *tag, uint8_t byte4)
{
	const size_t o = b.size();
	b.resize(o + kHeader);
	std::memcpy(b.data() + o, tag, 4);
	b[o + 4] = byte4;
}

void encode_data(const DataRow *rows, size_t n, Bytes &out, uint8_t byte4)
{
	out.resize(kHeader + kDataRecord * n);
	uint8_t *p = out.data();
	std::memcpy(p, "DATA", 4);
	p[4] = byte4;
	p += kHeader;
	for (size_t r = 0; r < n; r++, p += kDataRecord) {
		store_i32(p, rows[r].index);
		for (size_t c = 0; c < 8; c++)
			store_f32(p + 4 + 4 * c, rows[r].col[c]);
	}
}

Bytes encode_data(const std::vector<DataRow> &rows, uint8_t byte4)
{
	Bytes b;
	encode_data(rows.data(), rows.size(), b, byte4);
	return b;
}

std::vector<Bytes> encode_rref_replies(const std::vector<std::pair<int32_t, float>> &recs, uint8_t byte4)
{
	std::vector<Bytes> out;
	for (size_t i = 0; i < recs.size(); i += kRrefMaxRecords) {
		Bytes b;
		put_tag(b, "RREF", byte4);
		for (size_t k = i; k < recs.size() && k < i + kRrefMaxRecords; k++) {
			put_i32(b, recs[k].first);
			put_f32(b, recs[k].second);
		}
		out.push_back(std::move(b));
	}
	return out;
}

Msg message_type(const uint8_t *p, size_t len)
{
	if (len < kHeader)
		return Msg::Unknown;
	if (!std::memcmp(p, "DATA", 4))
		return Msg::Data;
	if (!std::memcmp(p, "DREF", 4))
		return Msg::Dref;
	if (!std::memcmp(p, "RREF", 4))
		return Msg::Rref;
	if (!std::memcmp(p, "DSEL", 4))
		return Msg::Dsel;
	if (!std::memcmp(p, "USEL", 4))
		return Msg::Usel;
	if (!std::memcmp(p, "CMND", 4))
		return Msg::Cmnd;
	if (!std::memcmp(p, "ISE4", 4))
		return Msg::Ise4;
	return Msg::Unknown;
}

// eight bytes as a little-endian word: p[0] the least significant byte
static uint64_t load_le64(const uint8_t *p)
{
	uint64_t w;
	std::memcpy(&w, p, 8);
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
	w = __builtin_bswap64(w);
#endif
	return w;
}

bool field_path(const uint8_t *field, size_t n, std::string_view &out)
{
	// One pass, eight bytes at a time: the first NUL ends the path, every byte before it
	// must be printable ASCII without space (0x21..0x7e). Per word, the lowest byte that
	// is 0 (is < 0x21, is > 0x7e) always shows as the high bit of its byte in `zero`
	// (`bad`); a borrow or carry only marks bytes above one that is itself 0 (bad), so a
	// mark below the first NUL always means a bad byte there.
	constexpr uint64_t ones = 0x0101010101010101ull, highs = 0x8080808080808080ull;
	size_t k = 0, len = 0;
	bool nul = false;
	for (; k + 8 <= n; k += 8) {
		const uint64_t w = load_le64(field + k);
		const uint64_t zero = (w - ones) & ~w & highs;
		const uint64_t bad = (((w - ones * 0x21) & ~w) | (w + ones) | w) & highs;
		if (zero) {
			const unsigned b = static_cast<unsigned>(__builtin_ctzll(zero)) / 8; // the NUL's byte
			if (bad & ((1ull << (8 * b)) - 1))
				return false;
			len = k + b;
			nul = true;
			break;
		}
		if (bad)
			return false;
	}
	for (; !nul && k < n; k++) {
		if (field[k] == 0) {
			len = k;
			nul = true;
		} else if (field[k] < 0x21 || field[k] > 0x7e) {
			return false;
		}
	}
	if (!nul || len == 0)
		return false;
	out = std::string_view(reinterpret_cast<const char *>(field), len);
	return true;
}

bool field_path(const uint8_t *field, size_t n, std::string &out)
{
	std::string_view v;
	if (!field_path(field, n, v))
		return false;
	out.assign(v);
	return true;
}

bool split_index(std::string_view path, std::string_view &base, int &index)
{
	size_t lb = path.find('[');
	if (lb == std::string_view::npos) {
		if (path.find(']') != std::string_view::npos)
			return false;
		base = path;
		index = -1;
		return true;
	}
	if (path.back() != ']' || lb + 2 > path.size() - 1 || path.size() - lb > 6)
		return false;
	int v = 0;
	for (size_t k = lb + 1; k + 1 < path.size(); k++) {
		char c = path[k];
		if (c < '0' || c > '9')
			return false;
		v = v * 10 + (c - '0');
	}
	base = path.substr(0, lb);
	index = v;
	return true;
}

bool split_index(const std::string &path, std::string &base, int &index)
{
	std::string_view b;
	if (!split_index(std::string_view(path), b, index))
		return false;
	base.assign(b);
	return true;
}

} // namespace xp
