"""Python client of DySAQUASIMs.

dysa.codec decodes the particle frames the server streams (server/codec/FORMAT.md).
"""
