"""The C++ snippets' plumbing (``*.inc`` beside this module, put into Warp modules with
``wp.func_native``): their text with its constants filled in, and the bit cast that
brings an int32 back from a float32 lane (a snippet returns one value, a vector)."""
from pathlib import Path

import numpy as np
import warp as wp

__all__ = ["snippet", "float_bits"]


def snippet(name: str, **constants) -> str:
    """``name``'s text with each ``@KEY@`` replaced: ints as they are, floats as the exact
    hexadecimal literal of their float32 value (what Warp's code multiplies by)."""
    text = Path(__file__).with_name(name).read_text()
    for key, value in constants.items():
        literal = str(value) if isinstance(value, int) else float(np.float32(value)).hex() + "f"
        text = text.replace(f"@{key}@", literal)
    return text


@wp.func_native("int bits; __builtin_memcpy(&bits, &x, 4); return bits;")
def float_bits(x: wp.float32) -> int:
    """The int32 whose bits ``x`` holds."""
