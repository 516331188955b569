// A small JSON reader/writer for the cornet-ns3 protocol (schema in README.md).
//
// Enough JSON for the messages we exchange: objects, arrays, strings (with \" \\ \/ \n \t \uXXXX
// escapes; \u is decoded only for ASCII), numbers, true/false/null. It avoids an extra build
// dependency (nlohmann-json) for ~150 lines. Parse errors throw std::runtime_error.
#pragma once

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace cornet
{

struct Json
{
    enum Type
    {
        Null,
        Bool,
        Number,
        String,
        Array,
        Object
    };

    Type type = Null;
    bool b = false;
    double n = 0.0;
    std::string s;
    std::vector<Json> a;
    std::map<std::string, Json> o;

    bool Has(const std::string& key) const
    {
        return type == Object && o.count(key) > 0;
    }

    const Json& operator[](const std::string& key) const
    {
        static const Json null;
        if (type != Object)
            throw std::runtime_error("not an object when reading key '" + key + "'");
        auto it = o.find(key);
        return it == o.end() ? null : it->second;
    }

    double Num(const std::string& key, double fallback) const
    {
        const Json& v = (*this)[key];
        if (v.type == Null)
            return fallback;
        if (v.type != Number)
            throw std::runtime_error("'" + key + "' must be a number");
        return v.n;
    }

    std::string Str(const std::string& key, const std::string& fallback) const
    {
        const Json& v = (*this)[key];
        if (v.type == Null)
            return fallback;
        if (v.type != String)
            throw std::runtime_error("'" + key + "' must be a string");
        return v.s;
    }
};

class JsonParser
{
  public:
    explicit JsonParser(const std::string& text)
        : m_text(text)
    {
    }

    Json Parse()
    {
        Json v = Value();
        Space();
        if (m_pos != m_text.size())
            Fail("trailing characters");
        return v;
    }

  private:
    const std::string& m_text;
    size_t m_pos = 0;

    [[noreturn]] void Fail(const std::string& what) const
    {
        throw std::runtime_error("JSON: " + what + " at offset " + std::to_string(m_pos));
    }

    void Space()
    {
        while (m_pos < m_text.size() && (m_text[m_pos] == ' ' || m_text[m_pos] == '\n' ||
                                         m_text[m_pos] == '\r' || m_text[m_pos] == '\t'))
            ++m_pos;
    }

    char Peek()
    {
        Space();
        if (m_pos >= m_text.size())
            Fail("unexpected end");
        return m_text[m_pos];
    }

    void Expect(char c)
    {
        if (Peek() != c)
            Fail(std::string("expected '") + c + "'");
        ++m_pos;
    }

    bool Literal(const char* word)
    {
        size_t len = std::char_traits<char>::length(word);
        if (m_text.compare(m_pos, len, word) == 0)
        {
            m_pos += len;
            return true;
        }
        return false;
    }

    Json Value()
    {
        Json v;
        char c = Peek();
        if (c == '{')
        {
            v.type = Json::Object;
            ++m_pos;
            if (Peek() == '}')
            {
                ++m_pos;
                return v;
            }
            while (true)
            {
                if (Peek() != '"')
                    Fail("expected a key");
                std::string key = StringBody();
                Expect(':');
                v.o[key] = Value();
                if (Peek() == ',')
                {
                    ++m_pos;
                    continue;
                }
                Expect('}');
                return v;
            }
        }
        if (c == '[')
        {
            v.type = Json::Array;
            ++m_pos;
            if (Peek() == ']')
            {
                ++m_pos;
                return v;
            }
            while (true)
            {
                v.a.push_back(Value());
                if (Peek() == ',')
                {
                    ++m_pos;
                    continue;
                }
                Expect(']');
                return v;
            }
        }
        if (c == '"')
        {
            v.type = Json::String;
            v.s = StringBody();
            return v;
        }
        if (Literal("true"))
        {
            v.type = Json::Bool;
            v.b = true;
            return v;
        }
        if (Literal("false"))
        {
            v.type = Json::Bool;
            return v;
        }
        if (Literal("null"))
            return v;
        const char* start = m_text.c_str() + m_pos;
        char* end = nullptr;
        v.n = std::strtod(start, &end);
        if (end == start)
            Fail("unexpected character");
        m_pos += static_cast<size_t>(end - start);
        v.type = Json::Number;
        return v;
    }

    std::string StringBody()
    {
        ++m_pos; // opening quote
        std::string out;
        while (m_pos < m_text.size())
        {
            char c = m_text[m_pos++];
            if (c == '"')
                return out;
            if (c != '\\')
            {
                out += c;
                continue;
            }
            if (m_pos >= m_text.size())
                break;
            char e = m_text[m_pos++];
            switch (e)
            {
            case 'n':
                out += '\n';
                break;
            case 't':
                out += '\t';
                break;
            case 'r':
                out += '\r';
                break;
            case 'b':
                out += '\b';
                break;
            case 'f':
                out += '\f';
                break;
            case 'u': {
                if (m_pos + 4 > m_text.size())
                    Fail("bad \\u escape");
                long code = std::strtol(m_text.substr(m_pos, 4).c_str(), nullptr, 16);
                m_pos += 4;
                out += code < 128 ? static_cast<char>(code) : '?';
                break;
            }
            default:
                out += e; // \" \\ \/
            }
        }
        Fail("unterminated string");
    }
};

inline std::string JsonQuote(const std::string& s)
{
    std::string out = "\"";
    for (char c : s)
    {
        if (c == '"' || c == '\\')
        {
            out += '\\';
            out += c;
        }
        else if (static_cast<unsigned char>(c) < 0x20)
        {
            char buf[8];
            std::snprintf(buf, sizeof buf, "\\u%04x", c);
            out += buf;
        }
        else
            out += c;
    }
    return out + "\"";
}

// Times go out with 9 decimals (nanoseconds, ns-3's resolution) so they round-trip exactly.
inline std::string JsonTime(double t)
{
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.9f", t);
    return buf;
}

} // namespace cornet
