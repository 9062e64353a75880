from django.contrib import admin

from .models import Answer, Condition, Participant, Study


class ConditionInline(admin.TabularInline):
    model = Condition
    fields = ("name", "position", "target")
    extra = 0


@admin.register(Study)
class StudyAdmin(admin.ModelAdmin):
    list_display = ("slug", "name", "is_open", "target_per_condition", "created_at")
    list_filter = ("is_open",)
    search_fields = ("slug", "name")
    readonly_fields = ("test_set", "source", "created_at")  # frozen once created (create_study)
    inlines = [ConditionInline]


@admin.register(Condition)
class ConditionAdmin(admin.ModelAdmin):
    list_display = ("name", "study", "position", "target")
    list_filter = ("study",)
    readonly_fields = ("training",)  # frozen once created


class AnswerInline(admin.TabularInline):
    model = Answer
    fields = ("step", "kind", "item", "data", "chosen_option", "correct", "confidence_score", "created_at")
    readonly_fields = fields
    extra = 0
    can_delete = False


@admin.register(Participant)
class ParticipantAdmin(admin.ModelAdmin):
    list_display = ("pk", "study", "condition", "platform", "platform_pid", "position", "started_at",
                    "completed_at", "excluded")
    list_filter = ("study", "condition", "platform", "excluded")
    search_fields = ("token", "platform_pid", "platform_session_id")
    readonly_fields = ("token", "option_orders", "started_at")
    inlines = [AnswerInline]


@admin.register(Answer)
class AnswerAdmin(admin.ModelAdmin):
    list_display = ("participant", "step", "kind", "item", "chosen_option", "correct", "confidence_score",
                    "created_at")
    list_filter = ("kind", "participant__study")
    search_fields = ("participant__token", "participant__platform_pid")
    readonly_fields = ("participant", "step", "kind", "item", "data", "chosen_option", "correct",
                       "confidence_score", "created_at")  # answers are write-once

    def has_add_permission(self, request):
        return False
