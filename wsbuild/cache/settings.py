"""What the command line and environment say about the cache (cheap to import: a no-op build
reads these settings but never opens the cache)."""

from __future__ import annotations

import re
import urllib.parse
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from wsbuild.errors import WsbuildError
from wsbuild.files import wsbuild_cache_dir
from wsbuild.patterns import lazy

DEFAULT_MAX_BYTES = 5 * 1024**3
DEFAULT_TIMEOUT = 3.0
#: WSBUILD_CACHE values that turn the cache off
OFF = frozenset({"off", "none", "no", "false", "0"})
_SIZE = lazy(r"\s*(\d+(?:\.\d+)?)\s*([kmgt]?)(?:i?b)?\s*", re.IGNORECASE)


@dataclass(frozen=True, slots=True)
class CacheSettings:
    """Where the build cache is and how it is used (local tier, remote URL, read-only)."""

    enabled: bool = True
    #: the remote tier's base URL (http or https), None for the local tier only
    url: str | None = None
    read_only: bool = False
    directory: Path | None = None
    max_bytes: int = DEFAULT_MAX_BYTES
    timeout: float = DEFAULT_TIMEOUT


def default_cache_dir(environ: Mapping[str, str]) -> Path:
    """WSBUILD_CACHE_DIR, else $XDG_CACHE_HOME/wsbuild, else ~/.cache/wsbuild."""
    return wsbuild_cache_dir(environ)


def parse_size(text: str) -> int:
    """'5G', '500M', '1.5GiB', '1024' → bytes (binary multiples)."""
    match = _SIZE.fullmatch(text)
    if match is None:
        raise WsbuildError(f"not a size: {text!r}", hint="write it like 5G, 500M or 1048576")
    number, unit = match.groups()
    return int(float(number) * 1024 ** " kmgt".index(unit.lower() or " "))


def redact(url: str) -> str:
    """The URL without user:password, for messages."""
    parsed = urllib.parse.urlsplit(url)
    if parsed.username is None and parsed.password is None:
        return url
    host = parsed.hostname or ""
    netloc = f"{host}:{parsed.port}" if parsed.port else host
    return urllib.parse.urlunsplit((parsed.scheme, netloc, parsed.path, parsed.query, parsed.fragment))


def check_cache_url(url: str) -> str:
    """The URL with a trailing slash removed; a usage error for anything but http(s)."""
    try:
        parsed = urllib.parse.urlsplit(url)
        parsed.port  # noqa: B018 (raises on a bad port)
    except ValueError:
        parsed = None
    if parsed is None or parsed.scheme not in ("http", "https") or not parsed.hostname:
        raise WsbuildError(f"unsupported cache URL {redact(url)!r}",
                           hint="give an http:// or https:// URL of a bazel-remote or "
                           "WebDAV server, e.g. --cache http://cache.example:8080/")
    if parsed.query or parsed.fragment:
        raise WsbuildError(f"cache URL {redact(url)!r} has a query or fragment",
                           hint="give the server's base URL only")
    return url.rstrip("/")


def settings_from_environment(environ: Mapping[str, str], *, url: str | None = None,
                              no_cache: bool = False, read_only: bool = False) -> CacheSettings:
    """Flags win over WSBUILD_CACHE (the remote URL, or `off`: no cache at all, not even the
    local one); WSBUILD_CACHE_MAX_SIZE bounds the local tier, WSBUILD_CACHE_TIMEOUT the
    seconds one request may wait."""
    from_env = environ.get("WSBUILD_CACHE", "").strip()
    if url is None and from_env.lower() in OFF:
        no_cache = True
        from_env = ""
    remote = url if url is not None else from_env or None
    if remote is not None and not no_cache:
        remote = check_cache_url(remote)
    max_bytes = DEFAULT_MAX_BYTES
    if environ.get("WSBUILD_CACHE_MAX_SIZE"):
        max_bytes = parse_size(environ["WSBUILD_CACHE_MAX_SIZE"])
    timeout = DEFAULT_TIMEOUT
    try:
        timeout = float(environ.get("WSBUILD_CACHE_TIMEOUT") or DEFAULT_TIMEOUT)
    except ValueError:
        pass
    return CacheSettings(enabled=not no_cache, url=remote, read_only=read_only,
                         directory=default_cache_dir(environ), max_bytes=max_bytes,
                         timeout=timeout)
