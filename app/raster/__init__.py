"""Raster passes on ModernGL: G-buffer, shadow maps, SSAO, forward lighting, tone mapping."""
