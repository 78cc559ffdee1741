#!/usr/bin/env python3
"""Checks the links of the user documentation: README.md, docs/*.md and scripts/measure/README.md.

    check_doc_links.py REPOSITORY_ROOT

- Every relative markdown link or image, [text](path), [text](path#anchor) or ![alt](path), must
  name a file or folder that exists, relative to the linking file; [text](#anchor) names the
  linking file itself.
- Every #anchor must be the anchor of a heading of the target file, by GitHub's rule: the
  heading's text (markup dropped) in lower case, every character that is not a letter, a digit, a
  space, '-' or '_' dropped, spaces turned into '-'; a repeated heading gets -1, -2, ...
- Every quoted section reference, NAME.md, "Heading" (docs/NAME.md, "Heading" from anywhere, or
  NAME.md beside the citing file), must name a heading of that file, its text exactly.

Links and citations inside code (fenced blocks and `spans`) are not read; http(s) and mailto
links are not followed. Prints one line per broken link, FILE:LINE: what, and exits 1 if there is
any; exits 0 otherwise.
"""
import os
import re
import sys

LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\]]*\])*\]\(\s*<?([^)\s>]*)>?(?:\s+\"[^\"]*\")?\s*\)")
CITATION = re.compile(r"((?:docs/)?[A-Za-z0-9_.-]+\.md),\s+\"([^\"]+)\"")
HEADING = re.compile(r"^ {0,3}(#{1,6})\s+(.*?)\s*#*\s*$")
FENCE = re.compile(r"^ {0,3}(```|~~~)")


def blank_code(text):
    """The text with fenced code blocks and inline code spans (which may wrap across the lines of a
    paragraph) replaced by spaces, line breaks and offsets kept."""
    out, fenced = [], None
    for line in text.split("\n"):
        m = FENCE.match(line)
        if fenced:
            out.append(" " * len(line))
            if m and m.group(1) == fenced:
                fenced = None
            continue
        if m:
            fenced = m.group(1)
            out.append(" " * len(line))
            continue
        out.append(line)
    blank = lambda s: re.sub(r"[^\n]", " ", s.group(0))
    return re.sub(r"(`+)(?:(?!\n[ \t]*\n).)+?\1", blank, "\n".join(out), flags=re.S)


def heading_texts(text):
    """(plain text, anchor) of every heading outside fenced code, in order."""
    headings, seen, fenced = [], {}, None
    for line in text.split("\n"):
        m = FENCE.match(line)
        if fenced:
            if m and m.group(1) == fenced:
                fenced = None
            continue
        if m:
            fenced = m.group(1)
            continue
        h = HEADING.match(line)
        if not h:
            continue
        plain = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", h.group(2))  # links: their text
        plain = re.sub(r"<[^>]+>", "", plain).replace("`", "").replace("*", "")
        slug = "".join(c for c in plain.lower() if c.isalnum() or c in " -_").replace(" ", "-")
        n = seen.get(slug, 0)
        seen[slug] = n + 1
        headings.append((plain.strip(), slug if n == 0 else f"{slug}-{n}"))
    return headings


def main():
    if len(sys.argv) != 2:
        raise SystemExit(__doc__)
    root = os.path.abspath(sys.argv[1])
    docs = os.path.join(root, "docs")
    files = [os.path.join(root, "README.md"), os.path.join(root, "scripts", "measure", "README.md")]
    files += sorted(os.path.join(docs, f) for f in os.listdir(docs) if f.endswith(".md"))
    cache = {}

    def headings_of(path):
        if path not in cache:
            with open(path, encoding="utf-8") as f:
                cache[path] = heading_texts(f.read())
        return cache[path]

    broken = []
    for path in files:
        if not os.path.isfile(path):
            broken.append(f"{os.path.relpath(path, root)}: missing")
            continue
        with open(path, encoding="utf-8") as f:
            text = f.read()
        readable = blank_code(text)
        here = os.path.dirname(path)
        name = os.path.relpath(path, root)

        def report(offset, what):
            broken.append(f"{name}:{text.count(chr(10), 0, offset) + 1}: {what}")

        for m in LINK.finditer(readable):
            target = m.group(1)
            if not target or re.match(r"^[a-z][a-z0-9+.-]*:", target, re.I):
                if not target:
                    report(m.start(), f"empty link {m.group(0)}")
                continue
            file_part, _, anchor = target.partition("#")
            resolved = os.path.normpath(os.path.join(here, file_part)) if file_part else path
            if not os.path.exists(resolved):
                report(m.start(), f"{target}: {os.path.relpath(resolved, root)} does not exist")
                continue
            if anchor:
                if not resolved.endswith(".md") or not os.path.isfile(resolved):
                    report(m.start(), f"{target}: an anchor into a file that is not markdown")
                elif anchor not in {slug for _, slug in headings_of(resolved)}:
                    report(m.start(), f"{target}: no heading of {os.path.relpath(resolved, root)} has the anchor #{anchor}")
        # Citations may wrap across lines: read them with the line breaks as spaces.
        for m in CITATION.finditer(readable.replace("\n", " ")):
            cited, heading = m.group(1), re.sub(r"\s+", " ", m.group(2)).strip()
            if cited.startswith("docs/"):
                resolved = os.path.join(root, cited)
            else:
                resolved = os.path.join(here, cited)
                if not os.path.isfile(resolved) and os.path.isfile(os.path.join(docs, cited)):
                    resolved = os.path.join(docs, cited)
            if not os.path.isfile(resolved):
                report(m.start(), f'{cited}, "{heading}": {cited} does not exist')
            elif heading not in {plain for plain, _ in headings_of(resolved)}:
                report(m.start(), f'{cited}, "{heading}": no such heading in {os.path.relpath(resolved, root)}')

    for line in broken:
        print(line)
    if broken:
        print(f"check_doc_links: {len(broken)} broken link(s) in {len(files)} files")
        return 1
    print(f"check_doc_links: {len(files)} files, every link resolves")
    return 0


if __name__ == "__main__":
    sys.exit(main())
