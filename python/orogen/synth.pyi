from typing import Any, Dict, Optional, Tuple, Union

import numpy as np

def noise(
    size: Union[int, Tuple[int, int], str] = ...,
    *,
    cell: float = ...,
    output: Any = ...,
    memory: Optional[str] = ...,
    tile: Optional[int] = ...,
    threads: int = ...,
    format: Optional[Dict[str, Any]] = ...,
    **params: Any,
) -> Any: ...
