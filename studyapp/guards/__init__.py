"""Guards against abuse: who may see researcher pages, rate limits, size caps, login lockout and CSV injection."""
