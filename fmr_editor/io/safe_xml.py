"""Reading XML files safely: bounded in size, parsed without DTD entities or external references."""

from __future__ import annotations

import os
from xml.etree.ElementTree import Element, ParseError

import defusedxml.ElementTree as defused_et
from defusedxml import DefusedXmlException, EntitiesForbidden

from .errors import DocumentLoadError

MAX_FILE_BYTES = 256 * 1024 * 1024
"""Larger files are refused before anything is read."""


class XmlRefused(ValueError):
    """What is wrong with an XML file's content (the file's name is added by the reader)."""


def read_bounded(path: str | os.PathLike, name: str) -> bytes:
    """The bytes of ``path``, refusing files above ``MAX_FILE_BYTES`` before reading (``DocumentLoadError``)."""
    try:
        if os.stat(path).st_size > MAX_FILE_BYTES:
            raise DocumentLoadError(name, f"the file is larger than {MAX_FILE_BYTES // 2**20} MiB")
        with open(path, "rb") as stream:
            data = stream.read(MAX_FILE_BYTES + 1)
    except FileNotFoundError:
        raise DocumentLoadError(name, "file not found") from None
    except (OSError, ValueError) as error:
        reason = getattr(error, "strerror", None) or str(error)
        raise DocumentLoadError(name, f"cannot read the file ({reason})") from None
    if len(data) > MAX_FILE_BYTES:
        raise DocumentLoadError(name, f"the file is larger than {MAX_FILE_BYTES // 2**20} MiB")
    return data


def parse_xml(data: bytes) -> Element:
    """The root element of ``data``, parsed without DTD entities or external references (``XmlRefused``)."""
    if len(data) > MAX_FILE_BYTES:
        raise XmlRefused(f"the file is larger than {MAX_FILE_BYTES // 2**20} MiB")
    try:
        return defused_et.fromstring(data, forbid_dtd=False, forbid_entities=True, forbid_external=True)
    except EntitiesForbidden:
        raise XmlRefused("the file declares XML entities, which are refused for safety") from None
    except DefusedXmlException as error:
        raise XmlRefused(f"the file uses an XML feature refused for safety ({error})") from None
    except (ParseError, ValueError, LookupError) as error:
        raise XmlRefused(f"not a well-formed XML file ({error})") from None
