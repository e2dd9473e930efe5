// json: a small JSON reader for --vehicle files (objects, arrays, numbers,
// strings, true/false/null; also NaN and [-]Infinity as Python writes them,
// so that callers can reject them by name). No dependencies; errors carry line and column.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

namespace json
{

struct Value {
	enum class Kind { Null, Bool, Number, String, Array, Object };
	Kind kind = Kind::Null;
	bool b = false;
	double num = 0.0;
	std::string str;
	std::vector<Value> arr;
	// insertion order is kept so that errors name keys in file order
	std::vector<std::pair<std::string, Value>> obj;

	const char *kind_name() const;
};

struct ParseError : std::runtime_error {
	using std::runtime_error::runtime_error;
};

// Parses a whole document; throws ParseError ("line L, column C: what").
Value parse(const std::string &text);

} // namespace json
