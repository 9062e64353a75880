from django.contrib import admin

from .models import Job, Part


class PartInline(admin.TabularInline):
    model = Part
    extra = 0
    fields = ("index", "key", "computed", "seconds", "items", "worker", "finished_at")
    readonly_fields = fields
    can_delete = False
    max_num = 0


@admin.register(Job)
class JobAdmin(admin.ModelAdmin):
    list_display = ("id", "kind", "label", "status", "chunks_done", "chunks_total", "created_at", "finished_at")
    list_filter = ("kind", "status")
    readonly_fields = ("canvas_id", "chunks_done", "chunks_computed", "trajectories_computed", "attempts",
                       "started_at", "finished_at", "error", "error_detail")
    inlines = [PartInline]
