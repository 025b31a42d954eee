"""Accounts of a team server: Argon2id password hashes, login sessions and API tokens stored as digests, share-link
secrets. No web framework here, so the command line manages accounts with the same functions the server uses."""

from __future__ import annotations

import datetime as dt
import hashlib
import re
import secrets

from argon2 import PasswordHasher
from argon2.exceptions import InvalidHashError, VerificationError, VerifyMismatchError
from sqlalchemy import select
from sqlalchemy.orm import Session

from ..errors import SightplanError
from .models import ROLES, Membership, Token, User, utcnow

SESSION_DAYS = 14
MIN_PASSWORD = 8
USERNAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._@-]{0,63}$")
_hasher = PasswordHasher()
# A hash of a random password, verified against when the user does not exist, so that a login takes as long for an
# unknown name as for a wrong password.
_DUMMY = _hasher.hash(secrets.token_urlsafe(16))


class AccountError(SightplanError):
    """An account that cannot be created or changed (a taken or malformed name, a short password, an unknown user)."""


def digest(secret: str) -> str:
    """What the database keeps of a session, token or link secret."""
    return hashlib.sha256(secret.encode()).hexdigest()


def new_secret(prefix: str) -> str:
    return f"{prefix}_{secrets.token_urlsafe(32)}"


def check_password(password: str) -> None:
    if len(password) < MIN_PASSWORD:
        raise AccountError(f"a password needs at least {MIN_PASSWORD} characters")




def find_user(session: Session, username: str) -> User | None:
    return session.scalars(select(User).where(User.username == username)).first()


def create_user(session: Session, username: str, password: str) -> User:
    if not USERNAME.match(username):
        raise AccountError(f"user name {username!r}: use 1 to 64 letters, digits or . _ @ -, starting with a letter "
                           "or digit")
    if find_user(session, username) is not None:
        raise AccountError(f"user {username!r} exists already")
    check_password(password)
    user = User(username=username, password_hash=_hasher.hash(password))
    session.add(user)
    session.flush()
    return user


def set_password(session: Session, user: User, password: str) -> None:
    """A new password; the user's sessions end (API tokens stay)."""
    check_password(password)
    user.password_hash = _hasher.hash(password)
    for token in session.scalars(select(Token).where(Token.user_id == user.id, Token.kind == "session")):
        session.delete(token)


def authenticate(session: Session, username: str, password: str) -> User | None:
    """The user if the password is right, else None (same work either way)."""
    user = find_user(session, username)
    try:
        _hasher.verify(user.password_hash if user is not None else _DUMMY, password)
    except (VerifyMismatchError, VerificationError, InvalidHashError):
        return None
    if user is None:
        return None
    if _hasher.check_needs_rehash(user.password_hash):
        user.password_hash = _hasher.hash(password)
    return user


def issue_token(session: Session, user: User, kind: str, name: str = "") -> tuple[Token, str]:
    """A new session (expires in 14 days) or API token (until revoked); the secret is returned once."""
    secret = new_secret("sps" if kind == "session" else "spt")
    expires = utcnow() + dt.timedelta(days=SESSION_DAYS) if kind == "session" else None
    token = Token(user_id=user.id, kind=kind, name=name[:200], digest=digest(secret), expires_at=expires)
    session.add(token)
    session.flush()
    return token, secret


def _aware(t: dt.datetime) -> dt.datetime:
    return t if t.tzinfo is not None else t.replace(tzinfo=dt.UTC)  # SQLite returns naive UTC times


def user_for_secret(session: Session, secret: str) -> User | None:
    """The user of a live session or API token, else None."""
    token = session.scalars(select(Token).where(Token.digest == digest(secret))).first()
    if token is None:
        return None
    now = utcnow()
    if token.expires_at is not None and _aware(token.expires_at) <= now:
        session.delete(token)
        return None
    token.last_used_at = now
    return token.user


def role_of(session: Session, project_id: int, user_id: int) -> str | None:
    return session.scalars(select(Membership.role).where(Membership.project_id == project_id,
                                                         Membership.user_id == user_id)).first()


def at_least(role: str | None, needed: str) -> bool:
    return role is not None and ROLES.index(role) >= ROLES.index(needed)
