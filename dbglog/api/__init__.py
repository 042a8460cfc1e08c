"""The publish side of dbglog: the typed logging functions (re-exported by ``dbglog``) and their machinery."""
