"""Where the lab listens and whom it answers: host and port checks, this machine's names.

The lab's page has no authentication, so the server answers only pages from its own origin;
these functions say which host names and addresses are this machine's.
"""

from __future__ import annotations

import ipaddress
import socket

from ..errors import RedundancyError

__all__ = ["check_address", "is_ip", "is_loopback", "machine_names"]


def check_address(host: str, port: int) -> None:
    """Check a host and port the lab can listen on.

    Raises:
        RedundancyError: ``port`` is not an integer in 0..65535 (0: any free port), or
            ``host`` is not an address or a name that resolves.
    """
    if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
        raise RedundancyError(
            f"port must be an integer in 0..65535 (0: any free port), got {port!r}"
        )
    if not isinstance(host, str) or not host:
        raise RedundancyError(f"host must be an address or a host name, got {host!r}")
    try:
        socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
    except (OSError, UnicodeError) as err:
        raise RedundancyError(f"cannot listen on host {host!r}: {err}") from err


def is_loopback(host: str) -> bool:
    """Whether every address ``host`` resolves to is a loopback address."""
    try:
        infos = socket.getaddrinfo(host, None, type=socket.SOCK_STREAM)
    except OSError:
        return False
    return all(ipaddress.ip_address(str(i[4][0]).split("%")[0]).is_loopback for i in infos)


def machine_names() -> set[str]:
    """Names and addresses under which this machine may be reached (for the Host check)."""
    names = {"localhost", "127.0.0.1", "::1", "[::1]"}
    for name in (socket.gethostname(), socket.getfqdn()):
        names.add(name.lower())
        try:
            for info in socket.getaddrinfo(name, None):
                addr = str(info[4][0])
                names.add(addr)
                names.add(f"[{addr}]")
        except OSError:
            pass
    return names


def is_ip(host: str) -> bool:
    """An address literal: a page served from it came from this server (no DNS to rebind)."""
    try:
        ipaddress.ip_address(host.strip("[]"))
    except ValueError:
        return False
    return True
