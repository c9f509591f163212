"""Whom the collector trusts over https: the plant's own CA, named in ``collector.toml``.

A plant's MTConnect agent and the REST service behind its reverse proxy (docs/guide/
rest-service.md) often carry certificates of the plant's own CA, which no public bundle holds.
``[service] ca_file`` and ``[mtconnect] ca_file`` name a PEM file of the CA certificates to
trust for that address (instead of the public bundle httpx brings, ``certifi``); without one,
the public bundle, or the file ``SSL_CERT_FILE`` names (httpx reads it). The file is read when
the configuration is checked, so a wrong path or a file that holds no certificate exits 2
naming the field, not at the first part; and a certificate the collector does not trust is
said so in its log, with the field that fixes it, not as a bare ``ConnectError``.
"""

from __future__ import annotations

import ssl
from pathlib import Path

from models.errors import InputError


def ca_file(given: str | None, section: str, url: str, base: Path) -> Path | None:
    """``[section] ca_file`` as ``given``, checked (None: not given); relative to ``base``.

    ``base``: the folder of ``collector.toml``.

    Raises
    ------
    InputError
        ``SECTION.ca_file``: given for an ``http://`` url, no such file, or no PEM
        certificate in it.
    """
    if given is None:
        return None
    field = f"{section}.ca_file"
    if not url.startswith("https://"):
        raise InputError(field, given, f"trusts a CA for https only; {section}.url is {url}")
    path = Path(given) if Path(given).is_absolute() else base / given
    if not path.is_file():
        raise InputError(field, given, f"no such file ({path})")
    try:
        trusted(path)
    except (ssl.SSLError, ValueError) as err:
        raise InputError(field, given, f"holds no PEM certificate of a CA ({err})") from None
    return path


def trusted(path: Path | None) -> ssl.SSLContext | bool:
    """What an ``httpx`` client verifies with: the CA file's context, else httpx's default."""
    if path is None:
        return True
    context = ssl.create_default_context(cafile=str(path))
    if not context.get_ca_certs():  # a PEM file of no certificate loads without a word
        raise ValueError("no certificate found")
    return context


def unreached(err: BaseException, field: str) -> str:
    """Why an address was not reached, for the log: a certificate not trusted names ``field``."""
    seen: BaseException | None = err
    while seen is not None:
        if isinstance(seen, ssl.SSLCertVerificationError):
            return (
                f"{type(err).__name__}: its certificate is not trusted ({seen.verify_message}); "
                f"{field} names the CA file to trust"
            )
        seen = seen.__cause__ or seen.__context__
    return type(err).__name__
