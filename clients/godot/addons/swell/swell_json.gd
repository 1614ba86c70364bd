extends RefCounted
## JSON whose numbers are read to the double nearest their decimal (correctly rounded, as Rust,
## JS and C# read them). Godot's JSON.parse_string (String.to_float) reads about one decimal in
## eight from swell's scene answers an ulp off; a wave's wavenumber or ω one ulp off moves its
## phase by up to an ulp times t, so the uniforms computed here would not be the server's bits.
##
## SwellJson.parse(text) parses with JSON.parse_string, then reads each number literal of the
## text again, in document order (Godot's dictionaries keep the order of their keys), with
## to_double. Most of swell's decimals (up to 15 significant digits, exponent within ±22) take a
## fast path: one multiplication or division of two exact doubles, which IEEE 754 rounds
## correctly. The rest compare the decimal exactly, in big integers, with the doubles around
## Godot's reading (a binary search over the doubles when that reading is further off, as it is
## near the subnormal range) and with the midpoint between the two that bracket it.

const _BASE := 16777216  # 2^24: a limb times 10^7 stays well inside 64 bits.
const _FRACTION := 4503599627370496  # 2^52
const _EXACT := 9007199254740992  # 2^53: integers up to it are exact doubles.

## 10^0 ... 10^22: every one an exact double (5^22 < 2^53), each the exact product of the last.
static var _p10: PackedFloat64Array = _powers_of_ten()


static func _powers_of_ten() -> PackedFloat64Array:
	var p := PackedFloat64Array([1.0])
	for i in 22:
		p.append(p[i] * 10.0)
	return p


## JSON.parse_string(text) with every number read by to_double; null when the text is not JSON.
## Where the numbers found in the text and in the parsed value do not pair up (duplicate keys),
## Godot's own reading is returned.
static func parse(text: String) -> Variant:
	var parsed = JSON.parse_string(text)
	if parsed == null:
		return null
	var literals := number_literals(text)
	var at := [0]
	var exact = _reread(parsed, literals, at)
	if at[0] != literals.size() or at[0] < 0:
		return JSON.parse_string(text)
	return exact


## The number literals of a JSON text, in order (none from inside strings).
static func number_literals(text: String) -> PackedStringArray:
	var out := PackedStringArray()
	var n := text.length()
	var i := 0
	var in_string := false
	while i < n:
		var c := text.unicode_at(i)
		if in_string:
			if c == 92:  # backslash: skip the escaped character
				i += 1
			elif c == 34:  # "
				in_string = false
			i += 1
		elif c == 34:
			in_string = true
			i += 1
		elif c == 45 or (c >= 48 and c <= 57):  # '-' or a digit
			var start := i
			i += 1
			while i < n:
				var d := text.unicode_at(i)
				if (d >= 48 and d <= 57) or d == 46 or d == 101 or d == 69 or d == 43 or d == 45:
					i += 1
				else:
					break
			out.append(text.substr(start, i - start))
		else:
			i += 1
	return out


static func _reread(v, literals: PackedStringArray, at: Array):
	match typeof(v):
		TYPE_FLOAT, TYPE_INT:
			if at[0] < 0:
				return v
			if at[0] >= literals.size():
				at[0] = -1
				return v
			var s: String = literals[at[0]]
			at[0] += 1
			# An integer Godot kept as an int is exact already.
			return to_double(s) if typeof(v) == TYPE_FLOAT else v
		TYPE_DICTIONARY:
			for k in v.keys():
				v[k] = _reread(v[k], literals, at)
			return v
		TYPE_ARRAY:
			for i in v.size():
				v[i] = _reread(v[i], literals, at)
			return v
	return v


## The double nearest the decimal `s` (JSON number syntax), ties to even.
static func to_double(s: String) -> float:
	var negative := s.begins_with("-")
	var body := s.substr(1) if negative else s
	var e10 := 0
	var e_at := body.findn("e")
	if e_at >= 0:
		e10 = body.substr(e_at + 1).to_int()
		body = body.substr(0, e_at)
	var dot := body.find(".")
	var digits := body
	if dot >= 0:
		digits = body.substr(0, dot) + body.substr(dot + 1)
		e10 -= body.length() - dot - 1
	digits = digits.lstrip("0")
	var x := 0.0
	if digits != "":
		var trimmed := digits.rstrip("0")
		e10 += digits.length() - trimmed.length()
		x = _positive(trimmed, e10)
	return -x if negative else x


## The double nearest D·10^e10, D the (nonzero, no leading or trailing zeros) integer `digits`.
static func _positive(digits: String, e10: int) -> float:
	if digits.length() <= 18:
		var d := digits.to_int()
		if d <= _EXACT and e10 >= -22 and e10 <= 22:
			return float(d) * _p10[e10] if e10 >= 0 else float(d) / _p10[-e10]
	# Far out of range: nothing to step between.
	if e10 + digits.length() > 310:
		return INF
	if e10 + digits.length() < -326:
		return 0.0
	# The largest double at or below the decimal: Godot's reading or a neighbour of it, else a
	# binary search over the bit patterns (ordered as the doubles are, for positive ones).
	var lo := _bits(("%se%d" % [digits, e10]).to_float())
	lo = clampi(lo, 0, _INF_BITS - 1)
	if not (_at_or_below(digits, e10, lo) and not _at_or_below(digits, e10, lo + 1)):
		if lo > 0 and _at_or_below(digits, e10, lo - 1) and not _at_or_below(digits, e10, lo):
			lo -= 1
		else:
			lo = 0
			var hi := _INF_BITS
			while hi - lo > 1:
				var mid := lo + (hi - lo) / 2
				if _at_or_below(digits, e10, mid):
					lo = mid
				else:
					hi = mid
	# Then up to the next double when the decimal is past the midpoint (on it: the even one).
	var mq := _split(lo)
	var c := _compare(digits, e10, 2 * mq[0] + 1, mq[1] - 1)
	if c > 0 or (c == 0 and (mq[0] & 1) == 1):
		lo += 1
	return _from_bits(lo)


const _INF_BITS := 0x7ff0000000000000


## The positive double with these bits as m·2^q: [m, q].
static func _split(bits: int) -> Array:
	var biased := bits >> 52
	var m := bits & (_FRACTION - 1)
	if biased == 0:
		return [m, -1074]
	return [m | _FRACTION, biased - 1075]


## Whether the double with bits `bits` (infinity for _INF_BITS) is at or below D·10^e10.
static func _at_or_below(digits: String, e10: int, bits: int) -> bool:
	if bits >= _INF_BITS:
		return false
	var mq := _split(bits)
	return _compare(digits, e10, mq[0], mq[1]) >= 0


## The sign of D·10^e10 − m·2^q, exactly.
static func _compare(digits: String, e10: int, m: int, q: int) -> int:
	var lhs := _big_from_digits(digits)
	var rhs := _big_from_int(m)
	if e10 >= 0:
		_big_mul_pow10(lhs, e10)
	else:
		_big_mul_pow10(rhs, -e10)
	if q >= 0:
		_big_mul_pow2(rhs, q)
	else:
		_big_mul_pow2(lhs, -q)
	return _big_cmp(lhs, rhs)


# Big integers: little-endian arrays of base-2^24 limbs.

static func _big_from_digits(digits: String) -> PackedInt64Array:
	var b := PackedInt64Array([0])
	var i := 0
	var n := digits.length()
	while i < n:
		var take := mini(7, n - i)
		_big_mul_small(b, int(_p10[take]), digits.substr(i, take).to_int())
		i += take
	return b


static func _big_from_int(v: int) -> PackedInt64Array:
	var b := PackedInt64Array()
	while v > 0:
		b.append(v % _BASE)
		v /= _BASE
	if b.is_empty():
		b.append(0)
	return b


## b = b·k + add, k and add below 2^24.
static func _big_mul_small(b: PackedInt64Array, k: int, add: int = 0) -> void:
	var carry := add
	for i in b.size():
		var v := b[i] * k + carry
		b[i] = v % _BASE
		carry = v / _BASE
	while carry > 0:
		b.append(carry % _BASE)
		carry /= _BASE


static func _big_mul_pow10(b: PackedInt64Array, n: int) -> void:
	while n >= 7:
		_big_mul_small(b, 10000000)
		n -= 7
	if n > 0:
		_big_mul_small(b, int(_p10[n]))


static func _big_mul_pow2(b: PackedInt64Array, n: int) -> void:
	while n >= 23:
		_big_mul_small(b, 1 << 23)
		n -= 23
	if n > 0:
		_big_mul_small(b, 1 << n)


static func _big_cmp(a: PackedInt64Array, b: PackedInt64Array) -> int:
	var na := a.size()
	while na > 1 and a[na - 1] == 0:
		na -= 1
	var nb := b.size()
	while nb > 1 and b[nb - 1] == 0:
		nb -= 1
	if na != nb:
		return 1 if na > nb else -1
	for i in range(na - 1, -1, -1):
		if a[i] != b[i]:
			return 1 if a[i] > b[i] else -1
	return 0


static func _bits(x: float) -> int:
	var b := PackedByteArray()
	b.resize(8)
	b.encode_double(0, x)
	return b.decode_s64(0)


static func _from_bits(n: int) -> float:
	var b := PackedByteArray()
	b.resize(8)
	b.encode_s64(0, n)
	return b.decode_double(0)
