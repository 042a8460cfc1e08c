"""Ground floor for regular expressions: numbers in lines and proposed RE2 patterns (stdlib, re2, numpy)."""
