"""Street layers to streetlight layouts (Chuang 2011, Sec. 3)."""
